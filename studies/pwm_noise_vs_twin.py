"""Study: the duty-quantisation noise model (``hil.model.pwm_noise``) against the simulated drive.

Run: ``.venv/bin/python studies/pwm_noise_vs_twin.py [--revolutions 8] [--counts 22 32 …]``
(≈ 30 s). For every operating point of the grid the twin (``hil.sim.DriveTwin``, the bench's
default drive: 1.6 kHz loop, 1.5 periods of delay, 1 kHz transducer) is captured as a
``hil run`` point would be (transducer torque, the plan's sample rate, R whole revolutions after
the settling time) and the non-synchronous RMS (``hil.analysis.nonsync``) is taken, with the
floor of a reference capture at the drive's default 2000 counts removed in quadrature (its own
modelled quantisation noise first taken out of it), exactly as the PWM-resolution plan does.
Printed per point: measured / model (twin ÷ quantised-loop model), the additive white-noise
form's ratio, and the twin against the smallest and the largest of the model's trials (the
expected range is [low·smallest, high·largest]); at the end the spread of each, from which
``NOISE_RANGE_FACTORS`` is set (twin ÷ smallest trial ≥ low, twin ÷ largest trial ≤ high).
The model never sees the twin's numbers.
"""

from __future__ import annotations

import argparse
import math

from hil.analysis.nonsync import nonsynchronous_rms
from hil.errors import InputError
from hil.model import OperatingPoint
from hil.model.pwm_noise import predict_noise
from hil.sim import DriveConfig, DriveTwin

PWM_HZ = 20_000.0
LOOP = {"current_loop_bandwidth_hz": 1600.0, "current_loop_delay_s": 75e-6,
        "transducer_bandwidth_hz": 1000.0, "pwm_frequency_hz": PWM_HZ}
REFERENCE_COUNTS = 2000
MAX_ORDER = 48


def capture_rate_hz(speed_rpm: float, pole_pairs: int = 2) -> float:
    """hil.measurement.PointPlan.capture_rate_hz for max_order 48 (10 points per period)."""
    needed = abs(speed_rpm) / 60.0 * pole_pairs * MAX_ORDER * 10
    return float(min(20_000.0, max(1_000.0, math.ceil(needed / 500.0) * 500.0)))


def twin_rms_pu(counts: int, op: OperatingPoint, revolutions: int, seed: int) -> float:
    """The twin's non-synchronous transducer RMS per unit of the nameplate mean torque."""
    twin = DriveTwin(DriveConfig(), seed=seed)
    twin.set_injection(pwm_period_counts=counts)
    twin.speed_rpm, twin.current_command_a = op.speed_rpm, op.current_a
    twin.enable()
    rate = capture_rate_hz(op.speed_rpm)
    twin.advance(0.05, rate)
    f_e = abs(op.speed_rpm) / 60.0 * op.motor.pole_pairs
    ch = twin.advance((revolutions + 0.25) / f_e, rate,
                      channels=["time_s", "torque_nm", "rotor_angle_mech_rad"])
    result = nonsynchronous_rms(ch["time_s"], ch["torque_nm"],
                                op.motor.pole_pairs * ch["rotor_angle_mech_rad"],
                                max_order=MAX_ORDER)
    return result.rms_nm / op.mean_torque_nm


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--revolutions", type=int, default=8)
    parser.add_argument("--counts", type=int, nargs="+", default=[22, 32, 48, 64, 128, 256])
    parser.add_argument("--speeds", type=float, nargs="+", default=[250, 500, 1000, 1500])
    parser.add_argument("--currents", type=float, nargs="+", default=[10, 20, 40])
    args = parser.parse_args()
    ratios, white, of_low, of_high = [], [], [], []
    print(f"R = {args.revolutions} revolutions, orders 0..{MAX_ORDER} removed; "
          "cells: twin % / model % (ratio; white-noise ratio)")
    for speed in args.speeds:
        for current in args.currents:
            try:
                op = OperatingPoint(speed_rpm=speed, current_a=current)
                ref_model = predict_noise(op, REFERENCE_COUNTS, revolutions=args.revolutions,
                                          max_order=MAX_ORDER, **LOOP).rms_pu
            except InputError as exc:
                print(f"{speed:g} rpm {current:g} A: refused ({exc})")
                continue
            reference = twin_rms_pu(REFERENCE_COUNTS, op, args.revolutions, seed=7)
            floor2 = max(reference ** 2 - ref_model ** 2, 0.0)
            cells = []
            for counts in args.counts:
                model = predict_noise(op, counts, revolutions=args.revolutions,
                                      max_order=MAX_ORDER, **LOOP)
                measured = math.sqrt(max(twin_rms_pu(counts, op, args.revolutions, seed=1) ** 2
                                         - floor2, 0.0))
                ratios.append(measured / model.rms_pu)
                white.append(measured / model.white_noise_rms_pu)
                of_low.append(measured / min(model.trials_rms_pu))
                of_high.append(measured / max(model.trials_rms_pu))
                cells.append(f"C{counts} {100 * measured:.3f}/{100 * model.rms_pu:.3f} "
                             f"({ratios[-1]:.2f}; {white[-1]:.2f}; trials' ends "
                             f"{of_low[-1]:.2f}/{of_high[-1]:.2f})")
            print(f"{speed:g} rpm {current:g} A, floor {100 * math.sqrt(floor2):.3f} %: "
                  + "  ".join(cells), flush=True)
    print(f"\ntwin / quantised-loop model over {len(ratios)} points: "
          f"{min(ratios):.2f} … {max(ratios):.2f} (median {sorted(ratios)[len(ratios) // 2]:.2f})")
    print(f"twin / white-noise model: {min(white):.2f} … {max(white):.2f}")
    print(f"twin / smallest trial >= {min(of_low):.2f}; twin / largest trial <= "
          f"{max(of_high):.2f} (NOISE_RANGE_FACTORS must hold both)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
