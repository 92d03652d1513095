"""Current-sensor gain mismatch (paper III-C, eqs 21-26): order-2 ripple, 2.31 % pk-pk for a
1 % mismatch of opposite signs (eq 26). Each point also judges the order-2 phase: it gives the
sign of k_a − k_b (``hil.model.gain_mismatch.order2_phasor``), which the magnitude cannot
(``ripple_hil_testplans.phase``)."""

import pytest

from ripple_hil_testplans import conditions as c
from ripple_hil_testplans.phase import phase_judge
from ripple_hil_testplans.sensitivity import check_sensitivity

pytestmark = pytest.mark.ripple_source("gain_mismatch")


def plan(config, injection):
    return c.point(config.operating_point, "gain_mismatch", injection, c.CLOSED_FORM_RULE,
                   phase=phase_judge(c.CLOSED_FORM_RULE.rel_tol))


@pytest.mark.parametrize("injection", c.GAIN_SWEEP, ids=c.sweep_id)
def test_gain_mismatch(measure, bench, injection):
    outcome = measure(plan(bench.config, injection))
    assert outcome.passed, outcome.summary()


def test_gain_mismatch_sensitivity(record):
    """The sweep's measured ripple scales with the injection as the model says (slope 1)."""
    result = check_sensitivity(record, "gain_mismatch", c.CLOSED_FORM_RULE.rel_tol)
    assert result["accepted"], result["statement"]
