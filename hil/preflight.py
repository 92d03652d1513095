"""Pre-flight: every point of every selected plan is checked before the first bench command.

A point that could only fail after the motor has run — a command beyond the bench limits or the
motor's voltage limit, a predicted order above the analysed band, a capture the DAQ cannot hold or
sample fast enough, an injection outside the drive's EDS range, a requirement on an order the
point does not analyse — is found here, from the bench file, the EDS and the DAQ register map
alone, and reported at collection time. Nothing is sent to the bench.
"""

from __future__ import annotations

import math

from hil.config import BenchConfig
from hil.errors import InputError


def voltage_needed_v(config: BenchConfig, speed_rpm: float, current_a: float,
                     current_angle_rad: float) -> float:
    """Peak phase voltage the drive must apply in steady state, V: |E + (R + jω_e·L)·I|
    with the current lagging the EMF by φ (paper eqs 1-4; Ke read as the bench file says)."""
    motor = config.motor
    omega_m = abs(speed_rpm) * 2.0 * math.pi / 60.0
    emf = motor.emf_peak_v_s_per_rad * omega_m
    omega_e = omega_m * motor.pole_pairs
    current = complex(math.cos(-current_angle_rad), math.sin(-current_angle_rad)) * current_a
    return abs(emf + complex(motor.phase_resistance_ohm, omega_e * motor.phase_inductance_h)
               * current)


def voltage_limit_v(config: BenchConfig) -> float:
    """The largest peak phase voltage of centre-aligned SVPWM without overmodulation, V_dc/√3."""
    return config.motor.dc_bus_v / math.sqrt(3.0)


def check_point(plan, config: BenchConfig, requirements=()) -> list[str]:
    """Every problem of one :class:`hil.measurement.PointPlan` on this bench (empty: fine)."""
    problems: list[str] = []
    limits = config.limits
    if abs(plan.speed_rpm) > limits.speed_rpm:
        problems.append(f"speed {plan.speed_rpm:g} rpm exceeds limits.speed_rpm = "
                        f"{limits.speed_rpm:g}")
    if not 0 <= plan.current_a <= limits.current_a:
        problems.append(f"current {plan.current_a:g} A outside 0..limits.current_a = "
                        f"{limits.current_a:g}")
    needed, available = (voltage_needed_v(config, plan.speed_rpm, plan.current_a,
                                          plan.current_angle_rad), voltage_limit_v(config))
    if needed > available:
        problems.append(f"needs {needed:.2f} V peak phase voltage at {plan.speed_rpm:g} rpm, "
                        f"{plan.current_a:g} A; the drive has {available:.2f} V (V_dc/√3)")
    problems += _capture_problems(plan, config)
    problems += _injection_problems(plan, config)
    problems += _order_problems(plan, config)
    problems += _requirement_problems(plan, requirements)
    return problems


def _capture_problems(plan, config: BenchConfig) -> list[str]:
    from ripple_hil_drivers.daq_register_map import load_register_map

    device = load_register_map(config.daq.register_map).device
    pole_pairs = config.motor.pole_pairs
    rate = plan.capture_rate_hz(pole_pairs)
    samples = int(round(plan.capture_duration_s(pole_pairs) * rate))
    problems = []
    if rate > float(device["max_sample_rate_hz"]):
        problems.append(f"capture rate {rate:g} Hz exceeds the DAQ's max_sample_rate_hz = "
                        f"{device['max_sample_rate_hz']}")
    if samples > int(device["buffer_capacity_samples"]):
        problems.append(f"capture of {samples} samples exceeds the DAQ's "
                        f"buffer_capacity_samples = {device['buffer_capacity_samples']}")
    nyquist_orders = rate / 2.0 / plan.electrical_frequency_hz(pole_pairs)
    if plan.analysis == "torque" and plan.max_order > nyquist_orders:
        problems.append(f"max_order {plan.max_order} is above what {rate:g} Hz can resolve at "
                        f"{plan.speed_rpm:g} rpm (order {nyquist_orders:.0f})")
    return problems


def _injection_problems(plan, config: BenchConfig) -> list[str]:
    from ripple_hil_drivers.canopen_eds import injection_objects

    knobs = injection_objects(config.drive.eds)
    problems = []
    for knob, value in plan.injection.items():
        if knob not in knobs:
            problems.append(f"injection {knob!r} is not a knob of the drive's EDS "
                            f"(known: {', '.join(sorted(knobs))})")
            continue
        try:
            knobs[knob].check_si(value)
        except (InputError, ValueError) as exc:
            problems.append(f"injection {knob}={value!r}: {exc}")
    return problems


def _order_problems(plan, config: BenchConfig) -> list[str]:
    if plan.rule is None:
        return []
    from hil.measurement import predicted_order

    try:
        order = predicted_order(plan, config.motor)
    except InputError as exc:
        return [f"prediction: {exc}"]
    if order is not None and order > plan.max_order:
        return [f"predicted order {order} is above the analysed band (max_order "
                f"{plan.max_order}); raise the plan's max_order"]
    return []


def _requirement_problems(plan, requirements) -> list[str]:
    from hil.requirements import applicable

    problems = []
    for req in applicable(requirements, source=plan.source, speed_rpm=plan.speed_rpm,
                          current_a=plan.current_a, injection=plan.injection):
        if req.order is not None and req.order > plan.max_order:
            problems.append(f"requirement {req.id} judges order {req.order}, above the point's "
                            f"analysed band (max_order {plan.max_order})")
    return problems


def check_plans(points: dict, config: BenchConfig, requirements=()) -> list[str]:
    """``{test id: PointPlan}`` → one line per problem, naming the test (empty: all fine); and
    every requirement whose injection names a knob the drive's EDS does not have (a typo that
    would silently make the line apply nowhere)."""
    lines = []
    for test_id, plan in points.items():
        lines += [f"{test_id}: {problem}" for problem in check_point(plan, config, requirements)]
    return lines + requirement_knob_problems(requirements, config)


def requirement_knob_problems(requirements, config: BenchConfig) -> list[str]:
    from ripple_hil_drivers.canopen_eds import injection_objects

    knobs = injection_objects(config.drive.eds)
    return [f"requirement {req.id}: injection knob {knob!r} is not a knob of the drive's EDS "
            f"(known: {', '.join(sorted(knobs))})"
            for req in requirements for knob, _ in req.injection if knob not in knobs]
