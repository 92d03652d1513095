"""Controller word length (paper III-B, eqs 10-14): the pk-pk ripple must stay within the
paper's worst-case bound 10/2^(n-1) (per unit of the full-scale-current torque, converted to the
operating point's mean torque by hil.model)."""

import pytest

from testplans import conditions as c

pytestmark = pytest.mark.ripple_source("word_length")


@pytest.mark.parametrize("injection", c.WORD_LENGTH_SWEEP, ids=c.sweep_id)
def test_word_length(measure, operating_point, injection):
    outcome = measure(c.point(operating_point, "word_length", injection, c.BOUND_RULE))
    assert outcome.verdict.guarded_pass, outcome.summary()
