"""What each plant can realise of the drive's injection knobs, known without importing it.

The pre-flight (``hil.validity.problems``) refuses, as *not determinable here* with the reason,
a point whose injection the bench's plant cannot really do; the plant itself refuses the same
value when the drive's object is written (SDO abort), so nothing is ever faked with another
model. The ripple-hil twin realises every knob.
"""

from __future__ import annotations

#: plant -> knob -> why the plant cannot realise a non-default value of it
UNSUPPORTED_KNOBS: dict[str, dict[str, str]] = {
    "motulator": {
        "word_length_bits": "motulator's current controller computes in floating point "
                            "(numpy float64); it has no fixed-point word length to set",
        "hall_mode": "the motulator plant's controller reads an encoder angle; it models no "
                     "Hall-sensor commutation (60° sectors with speed interpolation)",
    },
}

#: plant -> test-only defect (``hil.sim.defects``) -> why the plant cannot realise it
UNSUPPORTED_DEFECTS: dict[str, dict[str, str]] = {
    "motulator": {
        "word_length_offset_bits": "motulator's controller has no word length",
        "dead_time_compensation_pu": "the motulator plant's PWM runs without dead-time "
                                     "compensation (motulator PWM d_err=None)",
    },
}


def knob_refusal(plant: str, knob: str, value, default) -> str | None:
    """Why ``plant`` cannot run ``knob`` = ``value`` (None: it can; defaults always can)."""
    reason = UNSUPPORTED_KNOBS.get(plant, {}).get(knob)
    if reason is None or value == default:
        return None
    return f"injection {knob} = {value!r} cannot be realised by the {plant} plant: {reason}"


def plant_problems(plan, config) -> list[str]:
    """The injections of ``plan`` (a ``hil.measurement.PointPlan``) the bench's plant cannot
    realise: each a reason (empty on a real bench or the ripple-hil twin)."""
    plant = getattr(config, "sim_plant", "ripple-hil")
    if not config.simulated or plant not in UNSUPPORTED_KNOBS:
        return []
    from hil.sim.injection import Injection

    defaults = {name: r.default for name, r in Injection.ranges().items()}
    found = []
    for knob, value in plan.injection.items():
        reason = knob_refusal(plant, knob, value, defaults.get(knob))
        if reason:
            found.append(reason)
    return found


def defect_problems(plant: str, defects: dict) -> list[str]:
    """The test-only defects (``[simulation.defects]`` as a dict) ``plant`` cannot realise."""
    unsupported = UNSUPPORTED_DEFECTS.get(plant, {})
    return [f"simulation.defects.{name}: the {plant} plant cannot realise it: {unsupported[name]}"
            for name in defects if name in unsupported]
