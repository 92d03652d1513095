"""Current-sensor dc offset (paper III-C, eqs 15-20): order-1 ripple, 4 % pk-pk for 1 % offset
in both sensors (the worst case, eq 20). Offsets are swept as fractions of the current amplitude,
as in the paper, and injected in amperes. Each point also judges the order-1 phase: it names
the sensor and the sign of the offset (eq 19 as a phasor, ``hil.model.dc_offset.order1_phasor``),
which the magnitude cannot (``ripple_hil_testplans.phase``)."""

import pytest

from ripple_hil_testplans import conditions as c
from ripple_hil_testplans.phase import phase_judge
from ripple_hil_testplans.sensitivity import check_sensitivity

pytestmark = pytest.mark.ripple_source("dc_offset")


def plan(config, offset_a_pu, offset_b_pu):
    op = config.operating_point
    injection = {"ia_offset_a": offset_a_pu * op.current_a, "ib_offset_a": offset_b_pu * op.current_a}
    return c.point(op, "dc_offset", injection, c.CLOSED_FORM_RULE,
                   phase=phase_judge(c.CLOSED_FORM_RULE.rel_tol))


@pytest.mark.parametrize("offset_a_pu, offset_b_pu", c.DC_OFFSET_SWEEP_PU)
def test_dc_offset(measure, bench, offset_a_pu, offset_b_pu):
    outcome = measure(plan(bench.config, offset_a_pu, offset_b_pu))
    assert outcome.passed, outcome.summary()


def test_dc_offset_sensitivity(record):
    """The sweep's measured ripple scales with the injection as the model says (slope 1)."""
    result = check_sensitivity(record, "dc_offset", c.CLOSED_FORM_RULE.rel_tol)
    assert result["accepted"], result["statement"]
