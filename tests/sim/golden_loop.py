"""Reference runs of the twin's default current loop (the fixed design before it became
configurable). ``python -m tests.sim.golden_loop`` rewrote ``data/default_loop_golden.npz`` once,
from the commit before the loop options existed; the test compares today's output with it."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from hil.motor import MotorParameters
from hil.sim import DriveConfig, Injection, MotorModel, simulate

GOLDEN = Path(__file__).parent / "data" / "default_loop_golden.npz"
CHANNELS = ("ia_a", "ib_a", "torque_em_nm", "torque_nm", "ia_sensed_a", "va_v")
#: the motor the reference was stored with (Table I, Ke read as RMS phase EMF, the default then);
#: stated here so that a change of the Table I default reading does not touch the loop's check
MOTOR = MotorModel(parameters=MotorParameters(ke_definition="rms_phase"))

#: (name, config): the loop's paths that matter (float, fixed point, dead time, Hall, field angle)
CASES = {
    "default": DriveConfig(motor=MOTOR, current_command_a=20.0, speed_rpm=500.0),
    "dead_time_words": DriveConfig(motor=MOTOR, current_command_a=20.0, speed_rpm=1000.0,
                                   injection=Injection(dead_time_s=3e-6, word_length_bits=12,
                                                       current_angle_rad=math.radians(30))),
    "hall_offset": DriveConfig(motor=MOTOR, current_command_a=15.0, speed_rpm=-800.0,
                               injection=Injection(hall_mode=True, ia_offset_a=0.3,
                                                   pwm_period_counts=500)),
}


def run_cases(duration_s: float = 0.01, sample_rate_hz: float = 40_000.0) -> dict:
    out = {}
    for name, config in CASES.items():
        result = simulate(config, duration_s, sample_rate_hz, seed=1, settle_s=0.005)
        for channel in CHANNELS:
            out[f"{name}/{channel}"] = np.asarray(result[channel], dtype=np.float64)
    return out


if __name__ == "__main__":
    GOLDEN.parent.mkdir(exist_ok=True)
    np.savez_compressed(GOLDEN, **run_cases())
    print(f"wrote {GOLDEN}")
