"""Controller word length (paper III-B, eqs 10-14): the pk-pk ripple must stay within the
paper's worst-case bound 10/2^(n-1) (per unit of the full-scale-current torque, converted to the
operating point's mean torque by hil.model)."""

import pytest

from testplans import conditions as c

pytestmark = pytest.mark.ripple_source("word_length")


def plan(config, injection):
    return c.point(config.operating_point, "word_length", injection, c.BOUND_RULE,
                   expectation="judged against the paper's worst-case bound only (one-sided, no "
                               "order judged): the paper treats truncation errors as random, but "
                               "two's-complement truncation is biased by -1/2 LSB, which acts "
                               "like a dc offset on both current sensors (order-1 ripple)")


@pytest.mark.parametrize("injection", c.WORD_LENGTH_SWEEP, ids=c.sweep_id)
def test_word_length(measure, bench, injection):
    outcome = measure(plan(bench.config, injection))
    assert outcome.passed, outcome.summary()
