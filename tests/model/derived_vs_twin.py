"""Print the derived word-length and PWM-resolution forms beside the simulated drive over a grid.

Run: .venv/bin/python tests/model/derived_vs_twin.py   (about 15 s; not a test: no verdicts)
The twin's air-gap torque goes through hil.analysis (synchronous average, orders <= 48, as a
``hil run`` point); the grid is the one hil/model/README.md quotes (word length: 27 points at
8 revolutions; PWM resolution: 42 points at 2, 8 and 32 revolutions).
"""

from hil.analysis import analyze_capture
from hil.capture import Capture
from hil.errors import InputError
from hil.model import OperatingPoint, predict
from hil.sim import DriveTwin

LOOP = {"current_loop_bandwidth_hz": 1600.0, "current_loop_delay_s": 75e-6}  # the twin's
MAX_ORDER = 48


def twin_result(injection, speed_rpm, current_a, revolutions):
    twin = DriveTwin(seed=3)
    twin.set_injection(**injection)
    twin.speed_rpm, twin.current_command_a = speed_rpm, current_a
    twin.enable()
    twin.advance(0.1, 20_000.0)
    channels = twin.advance((revolutions + 0.1) * 60.0 / speed_rpm / 2, 20_000.0)
    capture = Capture({"time_s": channels["time_s"], "torque_nm": channels["torque_em_nm"],
                       "rotor_angle_mech_rad": channels["rotor_angle_mech_rad"]},
                      meta={"pole_pairs": 2})
    return analyze_capture(capture, max_order=MAX_ORDER)


def table(rows):
    inside, ratios = 0, []
    for label, measured, pred in rows:
        low, high = pred.expected_range_pu
        inside += low <= measured <= high
        ratios.append(measured / pred.pk_pk_pu)
        print(f"{label:<28} twin {100 * measured:7.3f} %  derived {100 * pred.pk_pk_pu:7.3f} % "
              f"[{100 * low:.3f}, {100 * high:.3f}]")
    print(f"-> {inside} of {len(rows)} in the expected range; twin/derived "
          f"{min(ratios):.2f} … {max(ratios):.2f}\n")


def main():
    rows = []
    for speed in (250, 500, 1000):
        for current in (10.0, 20.0, 40.0):
            for bits in (8, 10, 12):
                result = twin_result({"word_length_bits": bits}, speed, current, 8)
                pred = predict("word_length", OperatingPoint(speed, current),
                               word_length_bits=bits, model="derived", max_order=MAX_ORDER)
                rows.append((f"{speed} rpm {current:g} A {bits} bits", result.pk_pk_pu, pred))
    print("word length (8 revolutions)")
    table(rows)
    rows = []
    for speed in (250, 500, 1000, 1500):
        for current in (20.0, 40.0):
            try:
                op = OperatingPoint(speed, current)
            except InputError:
                continue  # beyond the voltage limit
            for counts in (32, 128):
                for revolutions in (2, 8, 32):
                    result = twin_result({"pwm_period_counts": counts}, speed, current,
                                         revolutions)
                    pred = predict("pwm_resolution", op, pwm_period_counts=counts,
                                   model="derived", max_order=MAX_ORDER,
                                   revolutions_averaged=result.revolutions, **LOOP)
                    rows.append((f"{speed} rpm {current:g} A C={counts} R={result.revolutions}",
                                 result.pk_pk_pu, pred))
    print("PWM resolution")
    table(rows)


if __name__ == "__main__":
    main()
