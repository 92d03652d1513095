"""Study: the PWM-switching plan at a small modulation index, and the region it is refused in
(issue 30; ``testplans/test_pwm_switching.MIN_MODULATION_INDEX``).

Run: ``.venv/bin/python studies/switching_modulation.py [--set calibration|holdout|both]``
(≈ 4 min on one core).

The within-period torque path under SVPWM is piecewise linear: two long zero-vector segments
of small slope and two short active-state segments of steep slope, whose ends are the path's
extremes (``hil.model.pwm_switching``). The plan's DAQ samples a few times per PWM period and
walks its sample phases over the G periods of a window (``hil.analysis.switching``). Where an
active state is shorter than the spacing of those phases, the samples straddle the steep
segment and the pk-pk reads low. That happens at a small modulation index: braking, where i·R
and the EMF nearly cancel (the 10-pole 48 V motor at −500 rpm / 20 A: M = 0.03, active states
of 2-3 µs against 2.6-5 µs sample phases; the plan read 0.37-0.67 of the model while the
twin's own ripple, sampled at 4 MHz, is 1.01-1.04 of it).

A second effect grows as M falls: the twin's own within-period ripple departs from the
switched-torque model (ideal switches, duties held over the period) by up to 1.5-2.7x at 40 kHz
and M ≤ 0.05, with the DAQ's sampling out of the question (reference below): the drive's 12-bit
current ADC makes its loop move the duties from period to period (hil/model/README.md).

For each point: the plan's capture settings at the DAQ's 200 kS/s (``capture_settings``); the
twin's currents captured there, ideal (no ADC step) and analysed by ``analyze_switching``; the
same twin's ripple at 400 samples per period from a carrier valley (the reference: what the path
really is); the model (``switched_torque``) and its modulation index M. The summary gives the
largest M on the calibration set at which the analysis reads beyond the plan's ±20 % of the
model (the plan's limit is set just above it) and counts the holdout points above that limit
that read beyond ±20 %.

Sets (disjoint in motor): calibration — Table I (4 poles, 12 V) and the 8-pole 48 V study
motor, both directions; holdout — the 10-pole and 14-pole 48 V study motors, both directions.
The twin runs the motor it is given; the model reads the same motor (the characterised one).
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from hil.analysis.switching import analyze_switching, capture_settings, window_periods
from hil.capture import Capture
from hil.model import OperatingPoint, predict
from hil.motor import TABLE_I, MotorParameters
from hil.sim import DriveConfig, DriveTwin, MotorModel
from ripple_hil_testplans.test_pwm_switching import MIN_MODULATION_INDEX

#: The simulated DAQ (hil/examples/sim-bench.toml's register map).
DAQ_MAX_RATE_HZ = 200_000.0
DAQ_BUFFER_SAMPLES = 200_000
MAX_ORDER = 24
REFERENCE_SAMPLES_PER_PERIOD = 400
FREQUENCIES_HZ = (10_000.0, 20_000.0, 40_000.0)
MOTORS = {
    "table_i": TABLE_I,
    "p8_48v": MotorParameters(pole_count=8, dc_bus_v=48.0, phase_resistance_ohm=0.12,
                              phase_inductance_h=0.3e-3, max_reactance_ohm=0.4,
                              ke_v_s_per_rad=0.06, ke_definition="rms_phase"),
    "p10_48v": MotorParameters(pole_count=10, dc_bus_v=48.0, phase_resistance_ohm=0.12,
                               phase_inductance_h=0.4e-3, max_reactance_ohm=0.5,
                               ke_v_s_per_rad=0.05, ke_definition="rms_phase"),
    "p14_48v": MotorParameters(pole_count=14, dc_bus_v=48.0, phase_resistance_ohm=0.1,
                               phase_inductance_h=0.3e-3, max_reactance_ohm=0.5,
                               ke_v_s_per_rad=0.04, ke_definition="peak_phase"),
}
POINTS = [(500.0, 20.0), (-500.0, 20.0), (250.0, 10.0), (-250.0, 10.0), (1200.0, 10.0),
          (-800.0, 15.0), (1000.0, 5.0)]
SETS = {"calibration": ("table_i", "p8_48v"), "holdout": ("p10_48v", "p14_48v")}
#: The plan's band (``CLOSED_FORM_RULE``): a reading beyond it is a wrong rejection.
BAND = 0.20


def twin_at(motor: MotorParameters, speed_rpm: float, current_a: float, pwm_hz: float):
    twin = DriveTwin(DriveConfig(motor=MotorModel(parameters=motor)), seed=1)
    twin.set_injection(pwm_frequency_hz=pwm_hz)
    twin.speed_rpm, twin.current_command_a = speed_rpm, current_a
    twin.enable()
    twin.advance(0.1, 10_000.0, channels=())
    return twin


def reference_pk_pk_pu(motor: MotorParameters, speed_rpm: float, current_a: float,
                       pwm_hz: float) -> float:
    """The twin's largest within-period pk-pk of Σ e_x·i_x/ω_m over one electrical revolution,
    400 samples per period from a carrier valley, per unit of its mean."""
    twin = twin_at(motor, speed_rpm, current_a, pwm_hz)
    twin.advance_to_carrier_valley()
    periods = int(pwm_hz / (abs(speed_rpm) / 60.0 * motor.pole_pairs))
    ch = twin.advance(periods / pwm_hz, pwm_hz * REFERENCE_SAMPLES_PER_PERIOD,
                      channels=["ia_a", "ib_a", "rotor_angle_mech_rad"])
    theta = motor.pole_pairs * ch["rotor_angle_mech_rad"]
    ia, ib = ch["ia_a"], ch["ib_a"]
    torque = motor.emf_peak_v_s_per_rad * (ia * np.sin(theta) + ib * np.sin(theta - 2 * math.pi / 3)
                                           + (-ia - ib) * np.sin(theta + 2 * math.pi / 3))
    n = torque.size // REFERENCE_SAMPLES_PER_PERIOD
    blocks = torque[:n * REFERENCE_SAMPLES_PER_PERIOD].reshape(n, -1)
    return float(np.ptp(blocks, axis=1).max() / abs(torque.mean()))


def evaluate(name: str, speed_rpm: float, current_a: float, pwm_hz: float) -> dict | str:
    motor = MOTORS[name]
    try:
        op = OperatingPoint(speed_rpm=speed_rpm, current_a=current_a, motor=motor)
    except Exception as exc:                      # beyond the voltage limit: not a point
        return f"refused by the model: {exc}"
    settings = capture_settings(speed_rpm, motor.pole_pairs, pwm_hz,
                                max_sample_rate_hz=DAQ_MAX_RATE_HZ,
                                buffer_samples=DAQ_BUFFER_SAMPLES, max_order=MAX_ORDER)
    if isinstance(settings, str):
        return settings
    prediction = predict("pwm_switching", op, pwm_frequency_hz=pwm_hz, model="switched_torque")
    twin = twin_at(motor, speed_rpm, current_a, pwm_hz)
    duration = settings.revolutions / (abs(speed_rpm) / 60.0 * motor.pole_pairs)
    channels = twin.advance(duration, settings.sample_rate_hz,
                            channels=["time_s", "ia_a", "ib_a", "rotor_angle_mech_rad"])
    capture = Capture(channels=channels, units={k: "" for k in channels},
                      meta={"pole_pairs": motor.pole_pairs})
    result = analyze_switching(capture, pwm_frequency_hz=pwm_hz, motor=motor, max_order=MAX_ORDER)
    reference = reference_pk_pk_pu(motor, speed_rpm, current_a, pwm_hz)
    return {"modulation_index": prediction.extras["modulation_index"],
            "spacing_us": 1e6 / pwm_hz / settings.effective_samples_per_period,
            "analysed": result.pk_pk_pu, "U": result.uncertainty.expanded_pu,
            "reference": reference, "model": prediction.pk_pk_pu,
            "G": window_periods(2 * math.pi * abs(speed_rpm) / 60 * motor.pole_pairs, pwm_hz)}


def run_set(name: str) -> list[dict]:
    rows = []
    print(f"\n== {name} ==")
    print(f"{'motor':>8} {'rpm':>6} {'A':>4} {'kHz':>4} {'M':>6} {'G':>3} {'spacing us':>10} "
          f"{'analysed/ref':>12} {'ref/model':>9} {'analysed/model':>14}")
    for motor in SETS[name]:
        for speed, current in POINTS:
            for pwm_hz in FREQUENCIES_HZ:
                row = evaluate(motor, speed, current, pwm_hz)
                if isinstance(row, str):
                    print(f"{motor:>8} {speed:6g} {current:4g} {pwm_hz / 1e3:4g}  refused: {row[:70]}")
                    continue
                rows.append(row)
                print(f"{motor:>8} {speed:6g} {current:4g} {pwm_hz / 1e3:4g} "
                      f"{row['modulation_index']:6.3f} {row['G']:3d} {row['spacing_us']:10.2f} "
                      f"{row['analysed'] / row['reference']:12.3f} "
                      f"{row['reference'] / row['model']:9.3f} "
                      f"{row['analysed'] / row['model']:14.3f}", flush=True)
    return rows


def outside(row: dict) -> bool:
    return abs(row["analysed"] / row["model"] - 1.0) > BAND


def threshold(rows: list[dict]) -> float:
    """The largest modulation index at which a row reads beyond the band."""
    return max((r["modulation_index"] for r in rows if outside(r)), default=0.0)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--set", choices=("calibration", "holdout", "both"), default="both")
    args = parser.parse_args(argv)
    names = list(SETS) if args.set == "both" else [args.set]
    results = {name: run_set(name) for name in names}
    if "calibration" in results:
        limit = threshold(results["calibration"])
        print(f"\ncalibration: the largest M reading beyond ±{BAND:.0%} of the model is "
              f"{limit:.3f}; the plan refuses M < {MIN_MODULATION_INDEX:g}")
        if "holdout" in results:
            above = [r for r in results["holdout"] if r["modulation_index"] >= MIN_MODULATION_INDEX]
            print(f"holdout: {sum(outside(r) for r in above)} of {len(above)} points at "
                  f"M >= {MIN_MODULATION_INDEX:g} read beyond ±{BAND:.0%}; below it "
                  f"{sum(outside(r) for r in results['holdout'] if r not in above)} of "
                  f"{len(results['holdout']) - len(above)}")


if __name__ == "__main__":
    main()
