"""Study: the dead-time models against the simulated drive, calibration and holdout sets.

Run: ``.venv/bin/python studies/dead_time_calibration.py [--set calibration|holdout|both]
[--quick] [--rel-tol 0.35 --phase-tol-deg 5 --a6-tol 0.15]`` (the plan's bands for the holdout) (both sets ≈ 30 s on one core; ``--quick``: every 4th point, for CI).

Each point must lie in the plan's validity region first (``hil.model.voltage.linear_limit_v``,
the plant corner order R/(L·|ω_e|) ≤ ``hil.validity.DEAD_TIME_MAX_PLANT_CORNER_ORDER`` — set
as this calibration set's largest judged, 54.6 at 125 rpm — and the bench floor against half
the pk-pk acceptance half-width, ``hil.validity``); a point outside it is printed as refused
and not judged, as the plan would refuse it.

Every point is captured as the dead-time plan captures it (``hil.measurement.PointPlan``
defaults: transducer torque, 8 electrical revolutions after 0.05 s, the plan's sample rate,
orders 1..48, order 6 named) from ``hil.sim.DriveTwin`` with the bench's default drive (1.6 kHz
continuous-design PI, 1.5 PWM periods of delay, 1 kHz transducer) and analysed by
``hil.analysis.analyze_torque``. Beside it: the six-step series (``average_voltage``) and the
current-clamping model (``current_clamping``, the one the plan judges against), both with the
loop and transducer the bench file states. The twin's numbers never enter a model.

Printed per point: measured pk-pk and its U (k = 2), both models' pk-pk (% of the nameplate mean
torque, as the plan states them), ratio measured/model, the order-6 phase measured, predicted and
its U (deg). At the end, for the current-clamping model, the relative tolerance the calibration
set needs for a guarded pass of every point (``rel_tol`` of the plan's rule:
max (|m − p| + U − abs_tol)/p) and the largest phase error + U, then the same figures on the
holdout set and whether every holdout point passes with the calibration's tolerances.

Sets (disjoint in motor, operating point and seed):
* calibration: Table I (4 poles, 12 V, L/R 0.70 ms), 250/500/1000 rpm × 10/20/40 A,
  500/1000 rpm × 5 A and 125/150 rpm × 5/10/20/40 A, forward, dead times 1, 2, 4 µs, seed 1;
* holdout: motor B (10 poles, 48 V, 0.12 Ω, 400 µH: L/R 3.3 ms) and motor C (2 poles, 24 V,
  0.4 Ω, 80 µH: L/R 0.20 ms) at other speeds and currents, both directions, dead times 1.5, 3 µs,
  seeds 11.., plus Table I at reverse rotation and other points.
"""

from __future__ import annotations

import argparse
import math
from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np

from hil.analysis import InstrumentUncertainty, analyze_torque
from hil.errors import InputError
from hil.measurement import PointPlan, dyno_speed_setpoint_rpm
from hil.model import OperatingPoint, predict
from hil.model.voltage import inverter_voltage_needed_v, linear_limit_v
from hil.motor import TABLE_I, MotorParameters
from hil.validity import (DEAD_TIME_MAX_PLANT_CORNER_ORDER, FLOOR_COUNTS, FLOOR_FRACTION,
                          acceptance_half_width_pu, plant_corner_order)
from ripple_hil_testplans.conditions import transducer_limited_rate
from hil.sim import DriveConfig, DriveTwin, MotorModel, TransducerModel

PWM_HZ = 20_000.0
LOOP = {"current_loop_bandwidth_hz": 1600.0, "current_loop_delay_s": 75e-6}
TRANSDUCER_HZ = 1000.0
#: the plan's absolute allowance: the bench's own floor (testplans/conditions.py)
ABS_TOL_PU = 0.001
INSTRUMENTS = InstrumentUncertainty(transducer_accuracy_class_pct=0.1,
                                    transducer_full_scale_nm=5.0)
#: the simulated bench's torque resolution, N·m (hil/examples/sim-bench.toml): the region's floor
TORQUE_RESOLUTION_NM = 0.0005

MOTOR_B = MotorParameters(pole_count=10, dc_bus_v=48.0, phase_resistance_ohm=0.12,
                          phase_inductance_h=400e-6, max_reactance_ohm=0.5,
                          ke_v_s_per_rad=0.05, ke_definition="rms_phase")
MOTOR_C = MotorParameters(pole_count=2, dc_bus_v=24.0, phase_resistance_ohm=0.4,
                          phase_inductance_h=80e-6, max_reactance_ohm=0.1,
                          ke_v_s_per_rad=0.04, ke_definition="peak_phase")
MOTORS = {"TableI": TABLE_I, "B": MOTOR_B, "C": MOTOR_C}


@dataclass(frozen=True)
class Point:
    motor: str
    speed_rpm: float
    current_a: float
    dead_time_s: float
    seed: int


def calibration_set() -> list[Point]:
    """Table I forward, seed 1: 250/500/1000 rpm × 10/20/40 A, 5 A at 500/1000 rpm (low
    current, where the PWM ripple's dead zone at the crossings matters) and 125/150 rpm ×
    5/10/20/40 A (the plant corner order up to 55, issue 30), × 1/2/4 µs."""
    points = [(s, i) for s in (250.0, 500.0, 1000.0) for i in (10.0, 20.0, 40.0)]
    points += [(500.0, 5.0), (1000.0, 5.0)]
    # issue 30: low speed, where the plant corner order R/(L·ω_e) is 45-55 (250 rpm: 27), so that
    # the region's corner limit is set on the calibration motor (most are refused by the floor)
    points += [(s, i) for s in (125.0, 150.0) for i in (5.0, 10.0, 20.0, 40.0)]
    return [Point("TableI", s, i, t, 1) for s, i in points for t in (1e-6, 2e-6, 4e-6)]


def holdout_set() -> list[Point]:
    points = []
    seed = 11
    for motor, speeds, currents in (("B", (150.0, -400.0, 900.0), (8.0, 25.0)),
                                    ("C", (300.0, -800.0, 1300.0), (5.0, 12.0)),
                                    ("TableI", (-300.0, -750.0, 400.0), (15.0, 30.0))):
        for s in speeds:
            for i in currents:
                for t in (1.5e-6, 3e-6):
                    points.append(Point(motor, s, i, t, seed))
                    seed += 1
    return points


def capture(point: Point, plan: PointPlan, transducer_bandwidth_hz: float = 1000.0):
    """The twin's transducer torque captured as the plan would (see the module docstring);
    ``transducer_bandwidth_hz`` the simulated transducer's first-order bandwidth (the bench
    file's 1 kHz unless a test makes it lag more). The dyno runs where the plan runs it: off a
    PWM carrier locked to the rotor (``hil.carrier_lock``)."""
    motor = MOTORS[point.motor]
    config = DriveConfig(motor=MotorModel(parameters=motor),
                         transducer=TransducerModel(bandwidth_hz=transducer_bandwidth_hz))
    twin = DriveTwin(config, seed=point.seed)
    twin.set_injection(dead_time_s=point.dead_time_s)
    twin.speed_rpm = dyno_speed_setpoint_rpm(plan, motor.pole_pairs, PWM_HZ)
    twin.current_command_a = point.current_a
    twin.enable()
    rate = plan.capture_rate_hz(motor.pole_pairs)
    twin.advance(plan.settle_s, rate)
    ch = twin.advance(plan.capture_duration_s(motor.pole_pairs), rate,
                      channels=["time_s", "torque_nm", "rotor_angle_mech_rad"])
    return analyze_torque(ch["time_s"], ch["torque_nm"],
                          motor.pole_pairs * ch["rotor_angle_mech_rad"],
                          max_order=plan.max_order, named_order=6, instruments=INSTRUMENTS)


def wrap(angle: float) -> float:
    return (angle + math.pi) % (2 * math.pi) - math.pi


def evaluate(point: Point) -> dict | None:
    motor = MOTORS[point.motor]
    op = OperatingPoint(speed_rpm=point.speed_rpm, current_a=point.current_a, motor=motor)
    try:
        six_step = predict("dead_time", op, dead_time_s=point.dead_time_s,
                           model="average_voltage", **LOOP)
        clamping = predict("dead_time", op, dead_time_s=point.dead_time_s,
                           model="current_clamping", transducer_bandwidth_hz=TRANSDUCER_HZ,
                           **LOOP)
    except InputError as exc:
        print(f"  {point}: refused by the model ({exc})")
        return None
    needed = inverter_voltage_needed_v(motor, point.speed_rpm, point.current_a, 0.0,
                                       dead_time_s=point.dead_time_s, pwm_frequency_hz=PWM_HZ)
    limit = linear_limit_v(motor.dc_bus_v, point.dead_time_s, PWM_HZ)
    if needed > limit:
        print(f"  {point}: refused (the plan's region), needs {needed:.2f} V > {limit:.2f} V "
              "(hil.model.voltage.linear_limit_v)")
        return None
    from ripple_hil_testplans.test_dead_time import DEAD_TIME_RULE

    corner = plant_corner_order(SimpleNamespace(motor=motor), point.speed_rpm)
    if corner > DEAD_TIME_MAX_PLANT_CORNER_ORDER:
        print(f"  {point}: refused (the plan's region), plant corner order {corner:.3g} > "
              f"{DEAD_TIME_MAX_PLANT_CORNER_ORDER:g} (hil.validity.corner_problems)")
        return None

    floor_pu = FLOOR_COUNTS * TORQUE_RESOLUTION_NM / op.mean_torque_nm
    half_width = acceptance_half_width_pu(DEAD_TIME_RULE, clamping.pk_pk_nm / op.mean_torque_nm,
                                          None)
    if floor_pu > FLOOR_FRACTION * half_width:
        print(f"  {point}: refused (the plan's region), floor {100 * floor_pu:.3f} % > "
              f"{FLOOR_FRACTION} x half-width {100 * half_width:.3f} %")
        return None
    # at the plan's capture rate (testplans/conditions.transducer_limited_rate)
    plan = transducer_limited_rate(
        PointPlan(source="dead_time", injection={"dead_time_s": point.dead_time_s},
                  speed_rpm=point.speed_rpm, current_a=point.current_a),
        SimpleNamespace(motor=motor, torque=SimpleNamespace(bandwidth_hz=TRANSDUCER_HZ)))
    result = capture(point, plan)
    nameplate = op.mean_torque_nm
    measured = result.pk_pk_nm / nameplate
    expanded = result.uncertainty.expanded_pu * abs(result.mean_torque_nm) / nameplate
    amp6 = result.amplitude_nm[5]
    phase_u = 2.0 * result.amplitude_u_nm[5] / amp6 if amp6 > 0 else math.inf
    amp6_predicted = clamping.extras["order6_amplitude_pu"] * abs(clamping.base_nm)
    return {"point": point, "measured": measured, "U": expanded,
            "a6_ratio": amp6 / amp6_predicted,
            "a6_U_rel": 2.0 * result.amplitude_u_nm[5] / amp6_predicted,
            "six_step": six_step.pk_pk_nm / nameplate,
            "clamping": clamping.pk_pk_nm / nameplate,
            "phase_measured": result.phase_rad[5],
            "phase_predicted": clamping.extras["order6_phase_rad"],
            "phase_U": phase_u}


def report(name: str, rows: list[dict], rel_tol: float | None, phase_tol: float | None,
           a6_tol: float | None = None):
    print(f"\n== {name}: {len(rows)} points (pk-pk % of nameplate; phase deg) ==")
    print(f"{'motor':>6} {'rpm':>7} {'A':>5} {'Td us':>5} {'meas':>7} {'U':>6} {'6-step':>7} "
          f"{'ratio':>6} {'clamp':>7} {'ratio':>6} {'ph meas':>8} {'ph pred':>8} {'U':>6} "
          f"{'A6 m/p':>6} {'U':>5}")
    needed, phase_needed, a6_needed, fails = [], [], [], []
    for r in rows:
        p = r["point"]
        err = abs(r["measured"] - r["clamping"])
        needed.append((err + r["U"] - ABS_TOL_PU) / r["clamping"])
        dphi = abs(wrap(r["phase_measured"] - r["phase_predicted"]))
        phase_needed.append(dphi + r["phase_U"])
        a6_needed.append(abs(r["a6_ratio"] - 1.0) + r["a6_U_rel"])
        print(f"{p.motor:>6} {p.speed_rpm:7g} {p.current_a:5g} {1e6 * p.dead_time_s:5g} "
              f"{100 * r['measured']:7.3f} {100 * r['U']:6.3f} {100 * r['six_step']:7.3f} "
              f"{r['measured'] / r['six_step']:6.2f} {100 * r['clamping']:7.3f} "
              f"{r['measured'] / r['clamping']:6.2f} {math.degrees(r['phase_measured']):8.1f} "
              f"{math.degrees(r['phase_predicted']):8.1f} {math.degrees(r['phase_U']):6.1f} "
              f"{r['a6_ratio']:6.3f} {r['a6_U_rel']:5.3f}")
        a6_fails = (a6_tol is not None and a6_tol > r["a6_U_rel"]
                    and abs(r["a6_ratio"] - 1.0) > a6_tol - r["a6_U_rel"])
        if rel_tol is not None and (err > rel_tol * r["clamping"] + ABS_TOL_PU - r["U"]
                                    or dphi > phase_tol - r["phase_U"] or a6_fails):
            fails.append(p)
    ratios = [r["measured"] / r["clamping"] for r in rows]
    six = [r["measured"] / r["six_step"] for r in rows]
    a6 = [r["a6_ratio"] for r in rows]
    print(f"measured/current-clamping: {min(ratios):.2f} … {max(ratios):.2f}; "
          f"measured/six-step: {min(six):.2f} … {max(six):.2f}; order-6 amplitude "
          f"measured/model: {min(a6):.3f} … {max(a6):.3f}")
    print(f"rel_tol needed for a guarded pass of every point: {max(needed):.3f}; "
          f"phase tolerance needed (|Δφ| + U): {math.degrees(max(phase_needed)):.1f} deg; "
          f"order-6 amplitude tolerance needed (|A6 ratio − 1| + U): {max(a6_needed):.3f}")
    if rel_tol is not None:
        print(f"with rel_tol {rel_tol:.2f}, phase tolerance {math.degrees(phase_tol):.0f} deg and "
              f"order-6 amplitude ±{a6_tol:.2f} (the calibration's, or the options given): "
              f"{len(rows) - len(fails)}/{len(rows)} holdout points pass"
              + "".join(f"\n  FAILS: {p}" for p in fails))
    return max(needed), max(phase_needed), max(a6_needed)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--set", choices=("calibration", "holdout", "both"), default="both")
    parser.add_argument("--quick", action="store_true", help="every 4th point only")
    parser.add_argument("--rel-tol", type=float, default=None,
                        help="judge the holdout with this rel_tol (default: the calibration's)")
    parser.add_argument("--phase-tol-deg", type=float, default=None)
    parser.add_argument("--a6-tol", type=float, default=None,
                        help="order-6 amplitude band for the holdout (default: the calibration's)")
    args = parser.parse_args()
    step = 4 if args.quick else 1
    rel_tol, phase_tol = args.rel_tol, (math.radians(args.phase_tol_deg)
                                        if args.phase_tol_deg else None)
    if args.set in ("calibration", "both"):
        rows = [r for r in map(evaluate, calibration_set()[::step]) if r]
        cal_rel, cal_phase, cal_a6 = report("calibration (Table I, forward, seed 1)", rows, None,
                                            None)
        rel_tol = rel_tol if rel_tol is not None else cal_rel
        phase_tol = phase_tol if phase_tol is not None else cal_phase
        a6_tol = args.a6_tol if args.a6_tol is not None else cal_a6
    if args.set in ("holdout", "both"):
        if args.set == "holdout":
            a6_tol = args.a6_tol
        if rel_tol is None or phase_tol is None or a6_tol is None:
            parser.error("--set holdout needs --rel-tol, --phase-tol-deg and --a6-tol")
        rows = [r for r in map(evaluate, holdout_set()[::step]) if r]
        report("holdout (motors B, C; Table I reverse/other points; seeds 11..)", rows,
               rel_tol, phase_tol, a6_tol)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
