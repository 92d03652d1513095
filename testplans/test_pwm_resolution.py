"""PWM pulse-width resolution (paper III-D, eqs 27-28): the duty register's step ΔV/V = 1/2^(n-1)
with n the counter bits; here the counter's counts per half period set the step.

Eq 28 is the torque change of one voltage step with the voltage applied open loop; the drive
closes a current loop around the PWM, which turns the step into a disturbance it rejects. Both
eq 28 and the closed-loop bound are one-sided (a drive ignoring the injection meets them), so the
plan judges against the derived duty-quantisation model of hil.model.pwm_resolution (two-sided,
its own stated range; simple acceptance — see conditions.DERIVED_RANGE_SIMPLE_RULE) and checks
that the ripple scales with the counter as the model says; the bound and eq 28 are recorded.
"""

import pytest

from ripple_hil_testplans import conditions as c
from ripple_hil_testplans.sensitivity import check_sensitivity

pytestmark = pytest.mark.ripple_source("pwm_resolution")


def plan(config, injection):
    # the derived form averages over as many revolutions as the point captures
    return c.point(config.operating_point, "pwm_resolution", injection,
                   c.DERIVED_RANGE_SIMPLE_RULE, revolutions=c.PWM_RESOLUTION_REVOLUTIONS,
                   prediction_params={"model": "derived", "max_order": 48,
                                      "revolutions_averaged": c.PWM_RESOLUTION_REVOLUTIONS,
                                      **c.current_loop(config)},
                   expectation="judged against the derived duty-quantisation model through the "
                               "drive's current loop (two-sided, its own stated range); the "
                               "closed-loop bound and the paper's open-loop eq 28 are recorded "
                               "for comparison only")


@pytest.mark.parametrize("injection", c.PWM_RESOLUTION_SWEEP, ids=c.sweep_id)
def test_pwm_resolution(measure, bench, injection):
    outcome = measure(plan(bench.config, injection))
    assert outcome.passed, outcome.summary()


def test_pwm_resolution_sensitivity(record):
    """The sweep's measured ripple scales with the counter as the derived model says."""
    result = check_sensitivity(record, "pwm_resolution", c.DERIVED_RANGE_SLOPE_TOL,
                               mode="scaling")
    assert result["accepted"], result["statement"]
