"""Equally spaced samples are produced by recurrence within a sub-segment (``hil.sim.kernel``):
they must equal the exact solution evaluated at each instant. Reference: the same drive advanced
one sample per call, so that every sample is the first of its call and is evaluated directly."""

from __future__ import annotations

import numpy as np

from hil.motor import MotorParameters
from hil.sim import DriveConfig, DriveTwin, Injection, MotorModel

RATE_HZ = 2e6                      # 100 samples per 20 kHz PWM period, ~10 per sub-segment
SAMPLES = 400
#: direct and recurrent evaluation differ by rounding only (a few ulps per step, up to ~25
#: steps); a wrong decay factor or harmonic step is off by > 1e-6 of the peak within a period
RELATIVE_TO_PEAK = 1e-11


def test_recurrent_samples_equal_direct_evaluation():
    motor = MotorModel(parameters=MotorParameters(ke_definition="rms_phase"),
                       emf_harmonics=((5, 0.02, 0.3), (7, 0.01, -0.2)), cogging=((24, 0.01, 0.1),))
    config = DriveConfig(motor=motor, current_command_a=20.0, speed_rpm=900.0,
                         injection=Injection(dead_time_s=2e-6, current_angle_rad=0.3))
    batch, single = DriveTwin(config), DriveTwin(config)
    batch.advance(0.0, RATE_HZ, settle_s=0.005)
    single.advance(0.0, RATE_HZ, settle_s=0.005)
    whole = batch.advance(SAMPLES / RATE_HZ, RATE_HZ)
    pieces = [single.advance(1.0 / RATE_HZ, RATE_HZ) for _ in range(SAMPLES)]
    for name in ("ia_a", "ib_a", "torque_em_nm", "torque_shaft_nm", "torque_nm", "iq_a", "id_a"):
        direct = np.concatenate([piece[name] for piece in pieces])
        assert direct.shape == whole[name].shape
        peak = np.abs(direct).max()
        worst = np.abs(whole[name] - direct).max()
        assert worst <= RELATIVE_TO_PEAK * peak, f"{name}: off by {worst / peak:.2e} of the peak"
