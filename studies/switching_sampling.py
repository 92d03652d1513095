"""Study: where the PWM-switching plan's DAQ cannot sample the ripple's extremes, and the limit
the plan refuses below (issue 30; ``testplans/test_pwm_switching.MIN_ACTIVE_SAMPLES``).

Run: ``.venv/bin/python studies/switching_sampling.py [--set calibration|holdout|both]``
(≈ 1 min per set on one core).

The within-period torque path under SVPWM is piecewise linear: two long zero-vector segments of
small slope and the active states, short and steep, whose ends are the path's extremes
(``hil.model.pwm_switching``). The plan's DAQ samples a few times per PWM period and walks its
sample phases over the G periods of a window (``hil.analysis.switching``). Where the active
states are shorter than the spacing of those phases, the samples straddle them and the pk-pk
reads low. The active states last (1.5…√3)·M of the period (M = V_pk/V_dc): braking, where i·R
and the EMF nearly cancel, a few per cent (the 10-pole 48 V motor at −500 rpm / 20 A: M = 0.051).

For each point, as the plan does it: the capture settings at the simulated DAQ's 200 kS/s
(``capture_settings``); the twin at the dyno speed the plan commands (``hil.carrier_lock``); its
currents quantised at the DAQ's 5 mA and analysed by ``analyze_switching``; the verdict of the
plan's rule (``decide`` with ``CLOSED_FORM_RANGE_RULE`` and the model's range, then the plan's
``unresolved``): pass, not
determinable, or a wrong rejection (the drive is correct). Beside it: the twin's own ripple at
400 samples per period from a carrier valley (the reference: what the path really is), the model
(``switched_torque``) and the number of sample phases on the active states,
``active_fraction_at_peak`` × effective samples per period, which the plan's limit reads.

Sets (disjoint in motor): calibration — Table I (4 poles, 12 V), the 8-pole and the 14-pole
48 V study motors; holdout — the 10-pole and 12-pole 48 V study motors; both directions, 5–25 A,
10/20/40 kHz. The limit is set just above the largest count of a calibration wrong rejection
that reads low;
the holdout's wrong rejections above it are counted, not used. Below the limit the plan
excuses only a reading *below* the model (the sampling cannot read high): "with the limit".
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from hil.analysis.decision import decide
from hil.analysis.switching import analyze_switching, capture_settings
from hil.capture import Capture
from hil.carrier_lock import unlocked_speed_rpm
from hil.model import OperatingPoint, predict
from hil.motor import TABLE_I, MotorParameters
from hil.sim import DriveConfig, DriveTwin, MotorModel
from ripple_hil_testplans.conditions import CLOSED_FORM_RANGE_RULE, CURRENT_ADC_STEP_A
from ripple_hil_testplans.test_pwm_switching import (ADC_MAX_SHARE, MAX_ORDER,
                                                     MIN_ACTIVE_SAMPLES, PREDICTION, reads_low,
                                                     unresolved)

#: The simulated DAQ (drivers/data/daq_registers.toml): rate, buffer, current LSB (A).
DAQ_MAX_RATE_HZ = 200_000.0
DAQ_BUFFER_SAMPLES = 200_000
DAQ_LSB_A = 0.005
REFERENCE_SAMPLES_PER_PERIOD = 400
FREQUENCIES_HZ = (10_000.0, 20_000.0, 40_000.0)
#: The twin's loop: proportional gain per PWM period ω_c·T_s of its PI at 0.08 of f_pwm.
LOOP_GAIN_PER_PERIOD = 2.0 * math.pi * 0.08


def _motor(poles: int, r: float, l: float, ke: float, ke_definition: str) -> MotorParameters:
    return MotorParameters(pole_count=poles, dc_bus_v=48.0, phase_resistance_ohm=r,
                           phase_inductance_h=l, max_reactance_ohm=0.5, ke_v_s_per_rad=ke,
                           ke_definition=ke_definition)


#: studies/validity.py's motors
MOTORS = {
    "table_i": TABLE_I,
    "p8_48v": _motor(8, 0.12, 0.3e-3, 0.06, "rms_phase"),
    "p10_48v": _motor(10, 0.12, 0.4e-3, 0.05, "rms_phase"),
    "p12_48v": _motor(12, 0.08, 0.25e-3, 0.05, "rms_phase"),
    "p14_48v": _motor(14, 0.1, 0.3e-3, 0.04, "peak_phase"),
}
POINTS = [(500.0, 20.0), (-500.0, 20.0), (250.0, 10.0), (-250.0, 10.0), (1200.0, 10.0),
          (-800.0, 15.0), (1000.0, 5.0), (-900.0, 25.0)]
SETS = {"calibration": ("table_i", "p8_48v", "p14_48v"), "holdout": ("p10_48v", "p12_48v")}
PASS, NOT_DETERMINABLE, WRONG = "pass", "not determinable", "WRONG REJECTION"


def twin_at(motor: MotorParameters, speed_rpm: float, current_a: float, pwm_hz: float,
            config: DriveConfig | None = None):
    """The twin (``config``, default: the motor with the default drive) settled at the point."""
    config = config or DriveConfig(motor=MotorModel(parameters=motor))
    twin = DriveTwin(config, seed=1)
    twin.set_injection(pwm_frequency_hz=pwm_hz)
    twin.speed_rpm, twin.current_command_a = speed_rpm, current_a
    twin.enable()
    twin.advance(0.1, 10_000.0, channels=())
    return twin


def reference_pk_pk_pu(motor: MotorParameters, speed_rpm: float, current_a: float,
                       pwm_hz: float) -> float:
    """The twin's largest within-period pk-pk of Σ e_x·i_x/ω_m over one electrical revolution,
    400 samples per period from a carrier valley, per unit of its mean."""
    return twin_torque_pk_pk_pu(None, motor, speed_rpm, current_a, pwm_hz)


def twin_torque_pk_pk_pu(config: DriveConfig | None, motor: MotorParameters, speed_rpm: float,
                         current_a: float, pwm_hz: float) -> float:
    """:func:`reference_pk_pk_pu` of the twin ``config`` (None: the motor, default drive)."""
    twin = twin_at(motor, speed_rpm, current_a, pwm_hz, config)
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
    # the plan's prediction: the drive's ADC step and loop gain per period (the twin's default
    # continuous PI at 0.08 of the PWM frequency) bound the ripple its ADC adds
    prediction = predict("pwm_switching", op, pwm_frequency_hz=pwm_hz, **PREDICTION,
                         current_adc_step_a=CURRENT_ADC_STEP_A,
                         loop_gain_per_period=LOOP_GAIN_PER_PERIOD)
    if prediction.extras["adc_dither_pu"] > ADC_MAX_SHARE * prediction.pk_pk_pu:
        return (f"refused by the plan: ADC bound {prediction.extras['adc_dither_pu']:.2g} pu > "
                f"{ADC_MAX_SHARE:g} x {prediction.pk_pk_pu:.2g} pu")
    dyno_rpm = unlocked_speed_rpm(speed_rpm, motor.pole_pairs, pwm_hz, settings.revolutions)
    twin = twin_at(motor, dyno_rpm, current_a, pwm_hz)
    duration = settings.revolutions / (abs(speed_rpm) / 60.0 * motor.pole_pairs)
    channels = twin.advance(duration, settings.sample_rate_hz,
                            channels=["time_s", "ia_a", "ib_a", "rotor_angle_mech_rad"])
    for name_ in ("ia_a", "ib_a"):
        channels[name_] = np.round(channels[name_] / DAQ_LSB_A) * DAQ_LSB_A
    capture = Capture(channels=channels, units={k: "" for k in channels},
                      meta={"pole_pairs": motor.pole_pairs,
                            "daq_lsb": {"ia_a": DAQ_LSB_A, "ib_a": DAQ_LSB_A}})
    result = analyze_switching(capture, pwm_frequency_hz=pwm_hz, motor=motor, max_order=MAX_ORDER)
    order = None if prediction.order is None else int(prediction.order)
    verdict = decide(result, prediction.pk_pk_pu, order, CLOSED_FORM_RANGE_RULE,
                     base_scale=abs(result.mean_torque_nm) / op.mean_torque_nm,
                     expected_range_pu=prediction.expected_range_pu)
    outcome = PASS if verdict.guarded_pass else (NOT_DETERMINABLE if unresolved(verdict)
                                                  else WRONG)
    active = prediction.extras["active_fraction_at_peak"] * settings.effective_samples_per_period
    # the plan: below the limit a low reading that does not pass is not determinable
    limited = NOT_DETERMINABLE if (active < MIN_ACTIVE_SAMPLES and outcome != PASS
                                   and reads_low(verdict)) else outcome
    return {"active_samples": active, "with_limit": limited, "low": reads_low(verdict),
            "modulation_index": prediction.extras["modulation_index"],
            "analysed": result.pk_pk_pu * abs(result.mean_torque_nm) / op.mean_torque_nm,
            "U": result.uncertainty.expanded_pu, "outcome": outcome,
            "reference": reference_pk_pk_pu(motor, dyno_rpm, current_a, pwm_hz),
            "model": prediction.pk_pk_pu}


def run_set(name: str) -> list[dict]:
    rows = []
    print(f"\n== {name} ==")
    print(f"{'motor':>8} {'rpm':>6} {'A':>4} {'kHz':>4} {'M':>6} {'active':>6} "
          f"{'analysed/ref':>12} {'ref/model':>9} {'analysed/model':>14} {'U/model':>7}  plan "
          "(with the limit)")
    for motor in SETS[name]:
        for speed, current in POINTS:
            for pwm_hz in FREQUENCIES_HZ:
                row = evaluate(motor, speed, current, pwm_hz)
                if isinstance(row, str):
                    print(f"{motor:>8} {speed:6g} {current:4g} {pwm_hz / 1e3:4g}  refused: "
                          f"{row[:70]}")
                    continue
                rows.append(row)
                print(f"{motor:>8} {speed:6g} {current:4g} {pwm_hz / 1e3:4g} "
                      f"{row['modulation_index']:6.3f} {row['active_samples']:6.2f} "
                      f"{row['analysed'] / row['reference']:12.3f} "
                      f"{row['reference'] / row['model']:9.3f} "
                      f"{row['analysed'] / row['model']:14.3f} {row['U'] / row['model']:7.3f}  "
                      f"{row['outcome']} ({row['with_limit']})", flush=True)
    return rows


def summary(name: str, rows: list[dict]) -> None:
    count = lambda key, outcome: sum(r[key] == outcome for r in rows)  # noqa: E731
    below = [r for r in rows if r["active_samples"] < MIN_ACTIVE_SAMPLES]
    print(f"{name}: {len(rows)} points; without the limit {count('outcome', PASS)} pass, "
          f"{count('outcome', NOT_DETERMINABLE)} not determinable, {count('outcome', WRONG)} "
          f"wrong rejections; with it {count('with_limit', PASS)} / "
          f"{count('with_limit', NOT_DETERMINABLE)} / {count('with_limit', WRONG)}; "
          f"{len(below)} points below {MIN_ACTIVE_SAMPLES:g} phases")


def run_chosen_sets(run, description: str, argv=None) -> dict[str, list[dict]]:
    """``run(set name)`` for the sets ``--set`` names (calibration, holdout or both)."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--set", choices=("calibration", "holdout", "both"), default="both")
    args = parser.parse_args(argv)
    names = list(SETS) if args.set == "both" else [args.set]
    return {name: run(name) for name in names}


def main(argv=None) -> None:
    results = run_chosen_sets(run_set, __doc__.splitlines()[0], argv)
    print()
    if "calibration" in results:
        wrong = [r["active_samples"] for r in results["calibration"]
                 if r["outcome"] == WRONG and r["low"]]
        print(f"calibration: the most sample phases on the active states at a wrong rejection "
              f"reading low: {max(wrong, default=0.0):.2f}; the plan's limit MIN_ACTIVE_SAMPLES = "
              f"{MIN_ACTIVE_SAMPLES:g}")
    for name, rows in results.items():
        summary(name, rows)


if __name__ == "__main__":
    main()
