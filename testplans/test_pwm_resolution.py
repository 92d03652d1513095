"""PWM pulse-width resolution (paper III-D, eqs 27-28): the duty register's step ΔV/V = 1/2^(n-1)
with n the counter bits; here the counter's counts per half period set the step.

Eq 28 is the torque change of one voltage step with the voltage applied open loop; the drive
closes a current loop around the PWM, which turns the step into a disturbance it rejects. The
plan therefore judges against the closed-loop bound of hil.model.pwm_resolution (same step, through
the loop's rejection) and records eq 28's figure beside it (prediction.extras).
"""

import pytest

from testplans import conditions as c

pytestmark = pytest.mark.ripple_source("pwm_resolution")


def plan(config, injection):
    return c.point(config.operating_point, "pwm_resolution", injection, c.BOUND_RULE,
                   prediction_params={"model": "closed_loop",
                                      "current_loop_bandwidth_hz":
                                          c.current_loop(config)["current_loop_bandwidth_hz"]},
                   expectation="judged against the closed-loop bound; the paper's open-loop "
                               "eq 28 is recorded for comparison only")


@pytest.mark.parametrize("injection", c.PWM_RESOLUTION_SWEEP, ids=c.sweep_id)
def test_pwm_resolution(measure, bench, injection):
    outcome = measure(plan(bench.config, injection))
    assert outcome.passed, outcome.summary()
