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
  For the shipped plans (their conftest's ``not_determinable_here``) the region is decided
  again after the characterisation stage, on the bench as characterised
  (``fixtures/preflight.py refusal_on_bench``): a voltage limit or floor moves with the motor it
  is computed from. Other plan folders keep the collection-time decision.
  So is a point that needs a knob the drive under test cannot inject (its drive profile leaves
  the knob out, :func:`missing_knob_refusal`): "the drive under test has no <knob>".
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
    hard ones (:func:`hard_problems`), a knob the drive lacks (:func:`missing_knob_refusal`) and
    those of its plan's validity region (:func:`hil.validity.problems`: a point outside it is not
    determinable, not an error)."""
    from hil import validity

    hard = hard_problems(plan, config, requirements)
    if _profile_problem(config) is not None:
        return hard             # the drive profile itself is wrong: nothing else is known
    missing = missing_knob_refusal(plan, config)
    return hard + ([missing] if missing else []) + validity.problems(plan, config)


def not_determinable_reason(plan, config: BenchConfig) -> str | None:
    """Why the point is not determinable here (a knob the drive lacks, then the first limit of
    its validity region), or None; None too when the drive profile is wrong, a hard problem
    that refuses the whole run (:func:`check_plans`)."""
    from hil import validity

    if _profile_problem(config) is not None:
        return None
    return missing_knob_refusal(plan, config) or validity.refusal(plan, config)


def _profile_problem(config: BenchConfig) -> str | None:
    """The one line of a drive profile that does not fit the drive's EDS, or None."""
    from ripple_hil_drivers.drive_profile import profile_for

    try:
        profile_for(config.drive)
    except InputError as exc:
        return str(exc)
    return None


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
    profile_problem = _profile_problem(config)
    if profile_problem is not None:
        return problems + [profile_problem]
    problems += _injection_problems(plan, config)
    problems += _order_problems(plan, config)
    problems += _requirement_problems(plan, requirements)
    return problems


def _injection_problems(plan, config: BenchConfig) -> list[str]:
    from ripple_hil_drivers.drive_profile import plan_knobs, profile_for

    knobs = profile_for(config.drive).knobs
    problems = []
    for knob, value in plan.injection.items():
        if knob not in plan_knobs():
            problems.append(f"injection {knob!r} is not a knob of the drive's EDS "
                            f"(known: {', '.join(sorted(plan_knobs()))})")
            continue
        if knob not in knobs:
            continue    # the drive lacks it: not determinable here (missing_knob_refusal)
        try:
            knobs[knob].check_si(value)
        except (InputError, ValueError) as exc:
            problems.append(f"injection {knob}={value!r}: {exc}")
    return problems


def missing_knob_refusal(plan, config: BenchConfig) -> str | None:
    """"the drive under test has no <knob>" when the point needs a knob (its injection or its
    current angle) at a value the drive cannot be set to: its profile leaves the knob out and the
    value differs from the one it runs at (``DriveProfile.value_si``); None otherwise."""
    from ripple_hil_drivers.drive_profile import plan_knobs, profile_for

    profile = profile_for(config.drive)
    needed = {**plan.injection, "current_angle_rad": plan.current_angle_rad}
    lacking = [knob for knob, value in needed.items()
               if knob in plan_knobs() and profile.lacks(knob, value)]
    if not lacking:
        return None
    return "; ".join(f"the drive under test has no {knob}" for knob in lacking)


def _order_problems(plan, config: BenchConfig) -> list[str]:
    if plan.rule is None:
        return []
    from hil import validity

    if validity.voltage_problems(plan, config) or validity.period_problems(plan, config):
        return []                # not determinable here (voltage limit, order not whole)
    from hil.measurement import predicted_order

    try:
        order = predicted_order(plan, config)
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
    from ripple_hil_drivers.drive_profile import plan_knobs

    knobs = plan_knobs()
    return [f"requirement {req.id}: injection knob {knob!r} is not a knob of the drive's EDS "
            f"(known: {', '.join(sorted(knobs))})"
            for req in requirements for knob, _ in req.injection if knob not in knobs]
