"""Study (issue 30): the dead-time and PWM-resolution readings of the correct simulated drive
against their models at several capture rates, at one motor and point.

Run: ``.venv/bin/python studies/capture_rate_vs_transducer.py [--motor p2_24v] [--point 250,5]
[--rates 2000,4000,7919,20000] [--revolutions 8]`` (≈ 10 s).

Each point is captured from ``hil.sim.DriveTwin`` as the plan captures it (transducer torque of
the bench's 1 kHz first-order transducer, settle, whole electrical revolutions, off the PWM
carrier's lock: ``hil.measurement.dyno_speed_setpoint_rpm``), but at each of the given DAQ
rates, and analysed by ``hil.analysis.analyze_torque`` (orders 1..48). The plan's own rate is
``hil.measurement.PointPlan.capture_rate_hz`` (48 orders × 10 points per period, ≥ 1 kHz) and,
since issue 30, at least ``conditions.MIN_RATE_PER_TRANSDUCER_BANDWIDTH`` × the transducer's
bandwidth. Printed: PWM resolution's measured/predicted pk-pk at C = 32, 64, 128 (the derived
model, ``revolutions_averaged`` as captured) and their geometric mean (the plan's sweep scale);
the dead time's pk-pk and order-6 amplitude at 2, 3, 4 µs against the current-clamping model,
and the drive's own pk-pk with nothing injected. The twin's numbers never enter a model.
"""

from __future__ import annotations

import argparse
import importlib.util
import math
from pathlib import Path

from hil.analysis import InstrumentUncertainty, analyze_torque
from hil.measurement import PointPlan, dyno_speed_setpoint_rpm
from hil.model import OperatingPoint, predict
from hil.motor import MotorParameters
from hil.sim import DriveConfig, DriveTwin, MotorModel, TransducerModel

PWM_HZ = 20_000.0
LOOP = {"current_loop_bandwidth_hz": 1600.0, "current_loop_delay_s": 75e-6}
TRANSDUCER_HZ = 1000.0
INSTRUMENTS = InstrumentUncertainty(transducer_accuracy_class_pct=0.1,
                                    transducer_full_scale_nm=5.0)


def study_motor(name: str) -> MotorParameters:
    """A motor of studies/validity.py MOTORS."""
    spec = importlib.util.spec_from_file_location("validity_study",
                                                  Path(__file__).with_name("validity.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    table = {key: value for key, value in module.MOTORS[name].items()
             if key not in ("model", "serial_number")}
    return MotorParameters(**table)


def capture(motor: MotorParameters, plan: PointPlan, rate_hz: float, seed: int = 1):
    twin = DriveTwin(DriveConfig(motor=MotorModel(parameters=motor),
                                 transducer=TransducerModel(bandwidth_hz=TRANSDUCER_HZ)),
                     seed=seed)
    twin.set_injection(**plan.injection)
    twin.speed_rpm = dyno_speed_setpoint_rpm(plan, motor.pole_pairs, PWM_HZ)
    twin.current_command_a = plan.current_a
    twin.enable()
    twin.advance(plan.settle_s, rate_hz)
    ch = twin.advance(plan.capture_duration_s(motor.pole_pairs), rate_hz,
                      channels=["time_s", "torque_nm", "rotor_angle_mech_rad"])
    return analyze_torque(ch["time_s"], ch["torque_nm"],
                          motor.pole_pairs * ch["rotor_angle_mech_rad"], max_order=48,
                          named_order=6, instruments=INSTRUMENTS)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--motor", default="p2_24v")
    parser.add_argument("--point", default="250,5", help="RPM,A")
    parser.add_argument("--rates", default="2000,4000,7919,20000", help="DAQ rates, Hz")
    parser.add_argument("--revolutions", type=int, default=8)
    args = parser.parse_args()
    motor = study_motor(args.motor)
    speed_rpm, current_a = (float(x) for x in args.point.split(","))
    rates = [float(x) for x in args.rates.split(",")]
    op = OperatingPoint(speed_rpm=speed_rpm, current_a=current_a, motor=motor)
    base_nm = op.mean_torque_nm
    plan_rate = PointPlan(source="dead_time", injection={}, speed_rpm=speed_rpm,
                          current_a=current_a).capture_rate_hz(motor.pole_pairs)
    corner = motor.phase_resistance_ohm / (motor.phase_inductance_h * abs(op.elec_speed_rad_s))
    print(f"{args.motor} at {speed_rpm:g} rpm / {current_a:g} A: f_e "
          f"{abs(op.elec_speed_rad_s) / 2 / math.pi:.3g} Hz, the order rule's rate "
          f"{plan_rate:g} Hz, plant corner order R/(L·ω_e) {corner:.3g}; "
          f"{args.revolutions} revolutions; pk-pk in % of the nameplate mean torque")
    print("\nPWM resolution (derived model), measured/predicted pk-pk:")
    for rate in rates:
        ratios = []
        for counts in (32, 64, 128):
            plan = PointPlan(source="pwm_resolution", injection={"pwm_period_counts": counts},
                             speed_rpm=speed_rpm, current_a=current_a,
                             revolutions=args.revolutions)
            model = predict("pwm_resolution", op, pwm_period_counts=counts, model="derived",
                            max_order=48, revolutions_averaged=args.revolutions, **LOOP)
            result = capture(motor, plan, rate)
            ratios.append(result.pk_pk_nm / abs(result.mean_torque_nm) / model.pk_pk_pu)
        scale = math.exp(sum(map(math.log, ratios)) / len(ratios))
        print(f"  {rate:7g} Hz: C=32/64/128 {' '.join(f'{r:.2f}' for r in ratios)}; "
              f"scale {scale:.2f}")
    print("\nDead time (current-clamping model): pk-pk meas ± U / model, order 6 meas/model:")
    for rate in rates:
        own = capture(motor, PointPlan(source="dead_time", injection={"dead_time_s": 0.0},
                                       speed_rpm=speed_rpm, current_a=current_a,
                                       revolutions=args.revolutions), rate)
        cells = [f"own {100 * own.pk_pk_nm / base_nm:.3f}"]
        for dead_time_s in (2e-6, 3e-6, 4e-6):
            plan = PointPlan(source="dead_time", injection={"dead_time_s": dead_time_s},
                             speed_rpm=speed_rpm, current_a=current_a,
                             revolutions=args.revolutions)
            model = predict("dead_time", op, dead_time_s=dead_time_s, model="current_clamping",
                            transducer_bandwidth_hz=TRANSDUCER_HZ, **LOOP)
            result = capture(motor, plan, rate)
            a6_model_nm = model.extras["order6_amplitude_pu"] * abs(model.base_nm)
            cells.append(f"{1e6 * dead_time_s:g} us {100 * result.pk_pk_nm / base_nm:.3f} ± "
                         f"{100 * result.uncertainty.expanded_pu:.3f} / "
                         f"{100 * model.pk_pk_nm / base_nm:.3f} "
                         f"(A6 {result.amplitude_nm[5] / a6_model_nm:.2f})")
        print(f"  {rate:7g} Hz: " + "; ".join(cells))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
