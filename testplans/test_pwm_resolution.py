"""PWM pulse-width resolution (paper III-D, eqs 27-28): the duty register's step ΔV/V = 1/2^(n-1)
with n the counter bits; here the counter's counts per half period set the step."""

import pytest

from testplans import conditions as c

pytestmark = pytest.mark.ripple_source("pwm_resolution")


@pytest.mark.parametrize("injection", c.PWM_RESOLUTION_SWEEP, ids=c.sweep_id)
def test_pwm_resolution(measure, operating_point, injection):
    outcome = measure(c.point(operating_point, "pwm_resolution", injection, c.BOUND_RULE))
    assert outcome.verdict.guarded_pass, outcome.summary()
