"""Expected scaling of the pk-pk ripple with the injected quantity, for checks across a sweep.

A plan that sweeps an injection (word length 8, 10, 12 bits; PWM counter 32, 64, 128; dead time
1, 2, 4 µs; offsets in %) can check the *measured* change between neighbouring points against the
change the model predicts: a drive that ignores or mis-scales the injection gets the slope wrong
even where each point alone sits inside a wide tolerance (issue 13, item 1).

``sensitivity(source, op, knob, values, **params)`` evaluates ``predict(source, op, knob=value,
**params)`` at each value (``params`` pick the model, e.g. ``model="derived"``) and returns the
slope between neighbouring points per natural step of the knob (``KNOB_STEPS``): per bit, per
halving of the PWM counter, per µs of dead time, per % of offset or gain error, and the ratio of
the pk-pk values, which is often better determined than the slope (a common model error cancels).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable

from hil.errors import InputError
from hil.model.core import OperatingPoint
from hil.model.sources import INJECTION_KNOBS, SOURCES, predict, source_parameters

#: knob → (name of one step, the knob's value in steps: f(value, op)).
KNOB_STEPS: dict[str, tuple[str, Callable[[float, OperatingPoint], float]]] = {
    "word_length_bits": ("bit", lambda v, op: float(v)),
    "pwm_period_counts": ("halving of the counter", lambda v, op: -math.log2(v)),
    "pwm_bits": ("bit", lambda v, op: float(v)),
    "dead_time_s": ("µs", lambda v, op: 1e6 * v),
    "ia_offset_a": ("% of I", lambda v, op: 100.0 * v / op.current_a),
    "ib_offset_a": ("% of I", lambda v, op: 100.0 * v / op.current_a),
    "offset_a_pu": ("% of I", lambda v, op: 100.0 * v),
    "offset_b_pu": ("% of I", lambda v, op: 100.0 * v),
    "ia_gain_error_pu": ("% gain error", lambda v, op: 100.0 * v),
    "ib_gain_error_pu": ("% gain error", lambda v, op: 100.0 * v),
    "encoder_decimation": ("count of decimation", lambda v, op: float(v)),
    "resolution_elec_rad": ("electrical degree", lambda v, op: math.degrees(v)),
    "pwm_frequency_hz": ("kHz", lambda v, op: 1e-3 * v),
}


@dataclass(frozen=True)
class Sensitivity:
    """Predicted pk-pk at each knob value and the slopes between neighbours (module docstring).

    ``pk_pk_pu[i]`` is per unit of each prediction's own base (as ``Prediction.pk_pk_pu``);
    ``slopes_pu[i]`` = (pk_pk_pu[i+1] − pk_pk_pu[i]) / (steps[i+1] − steps[i]) per ``step``;
    ``ratios[i]`` = pk_pk_pu[i+1] / pk_pk_pu[i] (None where pk_pk_pu[i] is 0).
    """

    source: str
    knob: str
    step: str
    values: list[float]
    steps: list[float]
    pk_pk_pu: list[float]
    expected_ranges_pu: list[tuple[float, float] | None]
    slopes_pu: list[float]
    ratios: list[float | None]
    params: dict[str, Any]

    def to_dict(self) -> dict[str, Any]:
        return {"source": self.source, "knob": self.knob, "step": self.step,
                "values": list(self.values), "steps": list(self.steps),
                "pk_pk_pu": list(self.pk_pk_pu),
                "expected_ranges_pu": [list(r) if r else None for r in self.expected_ranges_pu],
                "slopes_pu_per_step": list(self.slopes_pu), "ratios": list(self.ratios),
                "params": dict(self.params)}


def sensitivity(source: str, op: OperatingPoint, knob: str, values: list[float],
                **params: Any) -> Sensitivity:
    """Slopes of the predicted pk-pk of ``source`` against ``knob`` over ``values``."""
    if source not in SOURCES:
        raise InputError(f"unknown source {source!r} (allowed: {', '.join(SOURCES)})")
    if knob not in KNOB_STEPS or knob not in source_parameters(source):
        allowed = [name for name in source_parameters(source) if name in KNOB_STEPS]
        raise InputError(f"{source}: knob {knob!r} has no sensitivity (allowed: "
                         f"{', '.join(allowed)})")
    if knob in params:
        raise InputError(f"{knob} is the swept knob: give it in values, not as a parameter")
    values = list(values)
    if len(values) < 2:
        raise InputError(f"values must hold at least 2 knob values, got {len(values)}")
    step, to_steps = KNOB_STEPS[knob]
    steps = [to_steps(value, op) for value in values]
    if len(set(steps)) != len(steps):
        raise InputError(f"values of {knob} must differ from each other, got {values}")
    predictions = [predict(source, op, **params, **{knob: value}) for value in values]
    pk_pk = [p.pk_pk_pu for p in predictions]
    slopes = [(pk_pk[i + 1] - pk_pk[i]) / (steps[i + 1] - steps[i]) for i in range(len(values) - 1)]
    ratios = [pk_pk[i + 1] / pk_pk[i] if pk_pk[i] else None for i in range(len(values) - 1)]
    shown = {key: value for key, value in params.items() if key not in INJECTION_KNOBS
             or key == "current_angle_rad"}
    return Sensitivity(source=source, knob=knob, step=step, values=values, steps=steps,
                       pk_pk_pu=pk_pk, expected_ranges_pu=[p.expected_range_pu
                                                           for p in predictions],
                       slopes_pu=slopes, ratios=ratios, params=shown)
