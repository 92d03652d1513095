"""Current-sensor dc offset (paper III-C, eqs 15-20): order-1 ripple, 4 % pk-pk for 1 % offset
in both sensors (the worst case, eq 20). Offsets are swept as fractions of the current amplitude,
as in the paper, and injected in amperes."""

import pytest

from testplans import conditions as c

pytestmark = pytest.mark.ripple_source("dc_offset")


@pytest.mark.parametrize("offset_a_pu, offset_b_pu", c.DC_OFFSET_SWEEP_PU)
def test_dc_offset(measure, operating_point, offset_a_pu, offset_b_pu):
    amplitude_a = operating_point.current_a
    injection = {"ia_offset_a": offset_a_pu * amplitude_a, "ib_offset_a": offset_b_pu * amplitude_a}
    outcome = measure(c.point(operating_point, "dc_offset", injection, c.CLOSED_FORM_RULE))
    assert outcome.passed, outcome.summary()
