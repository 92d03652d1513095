"""Current-sensor gain mismatch (paper III-C, eqs 21-26): order-2 ripple, 2.31 % pk-pk for a
1 % mismatch of opposite signs (eq 26)."""

import pytest

from testplans import conditions as c

pytestmark = pytest.mark.ripple_source("gain_mismatch")


def plan(config, injection):
    return c.point(config.operating_point, "gain_mismatch", injection, c.CLOSED_FORM_RULE)


@pytest.mark.parametrize("injection", c.GAIN_SWEEP, ids=c.sweep_id)
def test_gain_mismatch(measure, bench, injection):
    outcome = measure(plan(bench.config, injection))
    assert outcome.passed, outcome.summary()
