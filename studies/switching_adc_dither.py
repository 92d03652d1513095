"""Study: the PWM-switching ripple the drive's own current ADC adds, and the bound the plan
allows for it (issue 29/30; ``hil.model.pwm_switching.ADC_DITHER_GAIN``).

Run: ``.venv/bin/python studies/switching_adc_dither.py [--set calibration|holdout|both]``
(≈ 1 s per twin run; ≈ 6 min for both sets on one core).

The switching model (``hil.model.pwm_switching``) assumes ideal switches and a loop whose
duties follow the ideal trajectory. The drive reads its currents through an ADC of step q
(12 bits over ±100 A: 48.8 mA); the loop's proportional action turns each reading's
quantisation error into a duty change from one PWM period to the next, and the current then
drifts within the period on top of the switching ripple: the within-period pk-pk grows. For
each point the twin's own within-period pk-pk of Σ e_x·i_x/ω_m (400 samples per period, the
largest over one electrical revolution, per unit of its mean; ``switching_sampling.
reference_pk_pk_pu``) is taken with the drive's 12-bit ADC and with a 24-bit one (otherwise the
same drive, seed and dyno setpoint); the difference, in current per ADC step,

    c = (p₁₂ − p₂₄) · I·cos φ / q

is what the ADC adds. The loop's gain per period g = ω_c·T_s (the twin runs
``bandwidth_per_pwm`` = 0.08 of the PWM frequency: g = 0.50) is varied (0.04, 0.08, 0.12 per
PWM period): c grows about as g², and ``c / g²`` is the gain the model's bound states.

Sets (disjoint in motor): calibration — Table I, the 8-pole and the 14-pole 48 V study motors;
holdout — the 10- and 12-pole 48 V motors; points at 5–20 A, both directions; 10 and 40 kHz.
The bound's gain is set just above the calibration set's largest ``c / g²`` and the holdout's
largest is printed beside it (counted, not used).
"""

from __future__ import annotations

import math

from hil.carrier_lock import unlocked_speed_rpm
from hil.model import OperatingPoint, predict
from hil.sim import DriveConfig, DriveTwin, MotorModel
from hil.sim.config import FirmwareModel, SensorModel
from ripple_hil_testplans.test_pwm_switching import PREDICTION
from switching_sampling import (MOTORS, REFERENCE_SAMPLES_PER_PERIOD, SETS, run_chosen_sets,
                                twin_torque_pk_pk_pu)

ADC_FULL_SCALE_A = 100.0
POINTS = [(250.0, 5.0), (1000.0, 5.0), (-250.0, 10.0), (500.0, 20.0), (-500.0, 20.0)]
FREQUENCIES_HZ = (10_000.0, 40_000.0)
BANDWIDTHS_PER_PWM = (0.04, 0.08, 0.12)
#: The drive's ADC and one so fine that its steps add nothing (the twin's limit).
ADC_BITS, FINE_ADC_BITS = 12, 24


def twin_pk_pk_pu(motor, speed_rpm: float, current_a: float, pwm_hz: float, adc_bits: int,
                  bandwidth_per_pwm: float) -> float:
    config = DriveConfig(motor=MotorModel(parameters=motor),
                         sensors=SensorModel(adc_bits=adc_bits,
                                             adc_full_scale_a=ADC_FULL_SCALE_A),
                         firmware=FirmwareModel(bandwidth_per_pwm=bandwidth_per_pwm))
    return twin_torque_pk_pk_pu(config, motor, speed_rpm, current_a, pwm_hz)


def run_set(name: str) -> list[dict]:
    step_a = 2.0 * ADC_FULL_SCALE_A / 2 ** ADC_BITS
    rows = []
    print(f"\n== {name} ==")
    print(f"{'motor':>8} {'rpm':>6} {'A':>4} {'kHz':>4} {'g':>5} {'model':>7} {'12 bit':>7} "
          f"{'24 bit':>7} {'c (q)':>6} {'c/g²':>5}")
    for motor_name in SETS[name]:
        motor = MOTORS[motor_name]
        for speed, current in POINTS:
            try:
                op = OperatingPoint(speed_rpm=speed, current_a=current, motor=motor)
            except Exception as exc:                 # beyond the voltage limit: not a point
                print(f"{motor_name:>8} {speed:6g} {current:4g}  refused: {str(exc)[:60]}")
                continue
            for pwm_hz in FREQUENCIES_HZ:
                model = predict("pwm_switching", op, pwm_frequency_hz=pwm_hz,
                                **PREDICTION).pk_pk_pu
                dyno = unlocked_speed_rpm(speed, motor.pole_pairs, pwm_hz, 8)
                for per_pwm in BANDWIDTHS_PER_PWM:
                    coarse, fine = (twin_pk_pk_pu(motor, dyno, current, pwm_hz, bits, per_pwm)
                                    for bits in (ADC_BITS, FINE_ADC_BITS))
                    gain = 2.0 * math.pi * per_pwm
                    c = (coarse - fine) * current * math.cos(op.current_angle_rad) / step_a
                    rows.append({"motor": motor_name, "g": gain, "c": c, "c_per_g2": c / gain ** 2,
                                 "fine_per_model": fine / model})
                    print(f"{motor_name:>8} {speed:6g} {current:4g} {pwm_hz / 1e3:4g} "
                          f"{gain:5.3f} {model:7.4f} {coarse:7.4f} {fine:7.4f} {c:6.3f} "
                          f"{c / gain ** 2:5.2f}", flush=True)
    return rows


def main(argv=None) -> None:
    results = run_chosen_sets(run_set, __doc__.splitlines()[0], argv)
    print(f"\n(twin at {REFERENCE_SAMPLES_PER_PERIOD} samples per PWM period)")
    for name, rows in results.items():
        ratios = [r["c_per_g2"] for r in rows]
        print(f"{name}: {len(rows)} runs; c/g² {min(ratios):.2f}–{max(ratios):.2f}; c "
              f"{min(r['c'] for r in rows):.3f}–{max(r['c'] for r in rows):.3f} ADC steps")


if __name__ == "__main__":
    main()
