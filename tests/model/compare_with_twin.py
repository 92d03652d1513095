"""Print closed-form predictions beside the simulated drive (hil.sim.DriveTwin), one point each.

Run: .venv/bin/python tests/model/compare_with_twin.py   (about 10 s; not a test: no verdicts)
The twin's ripple is measured by ``twin_ripple.twin_ripple`` (orders above ``max_order`` dropped).
"""

import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))

from hil.model import OperatingPoint, predict  # noqa: E402
from twin_ripple import twin_ripple  # noqa: E402

LOOP = {"current_loop_bandwidth_hz": 0.08 * 20000.0}  # the twin's FirmwareModel default
DELAY = {"current_loop_delay_s": 1.5 / 20000}


def main():
    op = OperatingPoint(speed_rpm=1000, current_a=20.0)
    op10 = OperatingPoint(speed_rpm=100, current_a=20.0, current_angle_rad=math.radians(10))
    rows = [
        ("baseline", {}, op, None, {}, 40),
        ("dc_offset", {"ia_offset_a": 0.2, "ib_offset_a": 0.2}, op, "dc_offset", {}, 40),
        ("gain_mismatch", {"ia_gain_error_pu": 0.02, "ib_gain_error_pu": -0.02}, op,
         "gain_mismatch", {}, 40),
        ("encoder dec 100, 100 rpm, φ 10°", {"encoder_decimation": 100}, op10, "encoder", {}, 400),
        ("dead_time 2 µs (average model)", {"dead_time_s": 2e-6}, op, "dead_time",
         {"model": "average_voltage", **DELAY, **LOOP}, 40),
        ("dead_time 2 µs (paper eq 38)", {"dead_time_s": 2e-6}, op, "dead_time", {}, 40),
        ("word_length 10 bits (bound)", {"word_length_bits": 10}, op, "word_length", {}, 200),
        ("word_length 10 bits (derived)", {"word_length_bits": 10}, op, "word_length",
         {"model": "derived"}, 64),
        ("pwm counts 32 (derived)", {"pwm_period_counts": 32}, op, "pwm_resolution",
         {"model": "derived", **LOOP, **DELAY}, 64),
        ("pwm counts 32 (closed-loop bound)", {"pwm_period_counts": 32}, op, "pwm_resolution",
         {"model": "closed_loop", **LOOP}, 40),
        ("pwm counts 32 (eq 28)", {"pwm_period_counts": 32}, op, "pwm_resolution", {}, 40),
        ("pwm switching 20 kHz (switched)", {"pwm_frequency_hz": 20000.0}, op, "pwm_switching",
         {"model": "switched_torque"}, 10**6),
        ("pwm switching 20 kHz (paper)", {"pwm_frequency_hz": 20000.0}, op, "pwm_switching", {},
         10**6),
    ]
    print(f"{'case':<36} {'twin pk-pk %':>12} {'predicted %':>12}")
    for name, injection, point, source, params, max_order in rows:
        twin = twin_ripple(injection, point, max_order=max_order)
        measured = twin.pk_pk_pu
        if source is None:
            predicted = float("nan")
        else:
            if params.get("model") == "derived" and source == "pwm_resolution":
                params = {**params, "revolutions_averaged": twin.revolutions}
            pred = predict(source, point, **injection, **params)
            predicted = pred.pk_pk_nm / point.mean_torque_nm
        print(f"{name:<36} {100 * measured:12.3f} {100 * predicted:12.3f}")


if __name__ == "__main__":
    main()
