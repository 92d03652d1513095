"""Pre-flight: every point of every selected plan is checked before the first bench command.

Two kinds of problem are found here, from the bench file, the EDS and the DAQ register map
alone, at collection time; nothing is sent to the bench:

- **hard** (:func:`hard_problems`): a command beyond the bench's ``[limits]``, an injection
  outside the drive's EDS range, a predicted order above the analysed band, a requirement on an
  order the point does not analyse. The run does not start (``pytest.UsageError``).
- **outside the plan's validity region** (:mod:`hil.validity`): reverse rotation where the model
  does not handle braking, the motor's voltage limit (dead time included), a capture the DAQ
  cannot hold or sample fast enough, a ripple below the bench's resolvable floor. That point is
  skipped as *not determinable here* with its reason (``fixtures/preflight.py``); the rest run.
"""

from __future__ import annotations

from hil.config import BenchConfig
from hil.errors import InputError


def voltage_needed_v(config: BenchConfig, speed_rpm: float, current_a: float,
                     current_angle_rad: float, dead_time_s: float = 0.0,
                     pwm_frequency_hz: float = 20_000.0) -> float:
    """Peak phase voltage the inverter must give in steady state, V: the phasor with the signed
    speed (reverse rotation under positive torque brakes) plus the dead time's loss along the
    current (``hil.model.voltage.inverter_voltage_needed_v``, paper eqs 1-4, 32-37)."""
    from hil.model.voltage import inverter_voltage_needed_v

    return inverter_voltage_needed_v(config.motor, speed_rpm, current_a, current_angle_rad,
                                     dead_time_s=dead_time_s, pwm_frequency_hz=pwm_frequency_hz)


def voltage_limit_v(config: BenchConfig) -> float:
    """The largest peak phase voltage of centre-aligned SVPWM without overmodulation, V_dc/√3."""
    from hil.model.voltage import svpwm_limit_v

    return svpwm_limit_v(config.motor.dc_bus_v)


def check_point(plan, config: BenchConfig, requirements=()) -> list[str]:
    """Every problem of one :class:`hil.measurement.PointPlan` on this bench (empty: fine): the
    hard ones (:func:`hard_problems`) and those of its plan's validity region
    (:func:`hil.validity.problems`: a point outside it is not determinable, not an error)."""
    from hil import validity

    return hard_problems(plan, config, requirements) + validity.problems(plan, config)


def hard_problems(plan, config: BenchConfig, requirements=()) -> list[str]:
    """What stops a run before it starts: the bench's safety ``[limits]``, an injection outside
    the drive's EDS, a predicted order above the analysed band, a requirement the point cannot
    judge (a plan or bench-file error, never a property of the point's physics)."""
    problems: list[str] = []
    limits = config.limits
    if abs(plan.speed_rpm) > limits.speed_rpm:
        problems.append(f"speed {plan.speed_rpm:g} rpm exceeds limits.speed_rpm = "
                        f"{limits.speed_rpm:g}")
    if not 0 <= plan.current_a <= limits.current_a:
        problems.append(f"current {plan.current_a:g} A outside 0..limits.current_a = "
                        f"{limits.current_a:g}")
    problems += _injection_problems(plan, config)
    problems += _order_problems(plan, config)
    problems += _requirement_problems(plan, requirements)
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
    from hil import validity

    if validity.voltage_problems(plan, config) or validity.period_problems(plan, config):
        return []                # not determinable here (voltage limit, order not whole)
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
    """``{test id: PointPlan}`` → one line per hard problem (:func:`hard_problems`), naming the
    test (empty: all fine; a point outside its validity region is skipped as not determinable by
    ``fixtures/preflight.py``, not refused here); and
    every requirement whose injection names a knob the drive's EDS does not have (a typo that
    would silently make the line apply nowhere)."""
    lines = []
    for test_id, plan in points.items():
        lines += [f"{test_id}: {problem}" for problem in hard_problems(plan, config, requirements)]
    return lines + requirement_knob_problems(requirements, config)


def requirement_knob_problems(requirements, config: BenchConfig) -> list[str]:
    from ripple_hil_drivers.canopen_eds import injection_objects

    knobs = injection_objects(config.drive.eds)
    return [f"requirement {req.id}: injection knob {knob!r} is not a knob of the drive's EDS "
            f"(known: {', '.join(sorted(knobs))})"
            for req in requirements for knob, _ in req.injection if knob not in knobs]
