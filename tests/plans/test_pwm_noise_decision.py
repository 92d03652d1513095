"""The PWM-resolution noise check's decision per counter (testplans/test_pwm_resolution.py,
noise_decision): simple acceptance against the model's range, as the range's factors were set
from the simulated drive's measured values (their scatter is inside them); a value outside whose
U is wide against the range and reaches into it is not determinable; wholly outside fails."""

import pytest

from ripple_hil_testplans.test_pwm_resolution import noise_decision

RANGE = (0.829e-2, 1.382e-2)        # table_i 250 rpm 10 A, C = 32 (old range, for scale)


@pytest.mark.parametrize("value,u,expected", [
    (0.843e-2, 0.016e-2, "pass"),              # inside, U past the edge: was "conditional pass"
    (1.10e-2, 0.01e-2, "pass"),
    (0.80e-2, 0.05e-2, "fail"),                # outside, U small against the half-width
    (0.50e-2, 0.05e-2, "fail"),                # wholly outside
    (0.70e-2, 0.20e-2, "not determinable"),    # U > ½ of the half-width, reaching in
    (0.20e-2, 0.40e-2, "fail"),                # U wide but wholly outside
    (1.50e-2, 0.20e-2, "not determinable"),
    (1.60e-2, 0.20e-2, "fail"),                # its interval ends beyond the range
])
def test_noise_decision(value, u, expected):
    assert noise_decision(value, u, *RANGE) == expected
