"""The fault-injection knobs ("Injection") of the drive under test, one name each everywhere.

The names, defaults and ranges are the project contract (COMMON.md): the EDS writer, the drivers,
the simulated drive and the test plans all check themselves against :meth:`Injection.ranges`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from typing import ClassVar, NamedTuple


class KnobRange(NamedTuple):
    """Allowed closed interval, default and unit of one knob (``unit`` "1" = dimensionless)."""

    min: float
    max: float
    default: float
    unit: str


_RANGES: dict[str, KnobRange] = {
    "ia_offset_a": KnobRange(-20.0, 20.0, 0.0, "A"),
    "ib_offset_a": KnobRange(-20.0, 20.0, 0.0, "A"),
    "ia_gain_error_pu": KnobRange(-0.2, 0.2, 0.0, "1 (per unit of the nominal sensor gain)"),
    "ib_gain_error_pu": KnobRange(-0.2, 0.2, 0.0, "1 (per unit of the nominal sensor gain)"),
    "encoder_decimation": KnobRange(1, 1800, 1, "counts"),
    "hall_mode": KnobRange(False, True, False, "bool"),
    "word_length_bits": KnobRange(0, 32, 0, "bits (0 = floating point, else 6..32)"),
    "pwm_period_counts": KnobRange(8, 65535, 2000, "counts"),
    "pwm_frequency_hz": KnobRange(2000.0, 50000.0, 20000.0, "Hz"),
    "dead_time_s": KnobRange(0.0, 10e-6, 0.0, "s"),
    "current_angle_rad": KnobRange(-math.pi / 2, math.pi / 2, 0.0, "rad"),
    # the loop's test signal (issue 29): a sine of this amplitude at this electrical order added
    # to the q-current reference, i_q* = I·cos φ + A·sin(k·θe) (θe the firmware's angle)
    "loop_test_amplitude_a": KnobRange(0.0, 10.0, 0.0, "A"),
    "loop_test_order": KnobRange(1, 400, 1, "1 (electrical order: cycles per electrical revolution)"),
}

_INTEGER_KNOBS = ("encoder_decimation", "word_length_bits", "pwm_period_counts", "loop_test_order")


@dataclass(frozen=True)
class Injection:
    """Controller limitations injected into the drive (defaults: none; see COMMON.md table).

    ``current_angle_rad`` is φ of eq (4): the current lags the back EMF by φ.
    ``word_length_bits`` is n of eq (14): 0 means floating point, else 6..32.
    ``loop_test_amplitude_a``, ``loop_test_order``: the current loop's test signal, A·sin(k·θe)
    on the q-current reference (not a fault: the characterisation measures the loop with it).
    """

    ia_offset_a: float = 0.0
    ib_offset_a: float = 0.0
    ia_gain_error_pu: float = 0.0
    ib_gain_error_pu: float = 0.0
    encoder_decimation: int = 1
    hall_mode: bool = False
    word_length_bits: int = 0
    pwm_period_counts: int = 2000
    pwm_frequency_hz: float = 20000.0
    dead_time_s: float = 0.0
    current_angle_rad: float = 0.0
    loop_test_amplitude_a: float = 0.0
    loop_test_order: int = 1

    FIELDS: ClassVar[tuple[str, ...]] = tuple(_RANGES)

    def __post_init__(self) -> None:
        self.validate()

    @classmethod
    def ranges(cls) -> dict[str, KnobRange]:
        """``{name: KnobRange(min, max, default, unit)}`` for every knob, in contract order."""
        return dict(_RANGES)

    def validate(self) -> None:
        """Raise ValueError naming the field, the bad value and the allowed range."""
        for name in self.FIELDS:
            value = getattr(self, name)
            low, high, _, unit = _RANGES[name]
            if name == "hall_mode":
                if not isinstance(value, (bool, int)) or value not in (0, 1):
                    raise ValueError(f"injection {name} must be a bool, got {value!r}")
                continue
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise ValueError(f"injection {name} must be a number in [{low}, {high}] {unit}, "
                                 f"got {value!r}")
            if name in _INTEGER_KNOBS and int(value) != value:
                raise ValueError(f"injection {name} must be an integer in [{low}, {high}], "
                                 f"got {value!r}")
            if not (low <= value <= high) or math.isnan(value):
                raise ValueError(f"injection {name}={value!r} is outside the allowed range "
                                 f"[{low}, {high}] {unit}")
            if name == "word_length_bits" and 0 < value < 6:
                raise ValueError(f"injection word_length_bits={value!r} must be 0 (floating "
                                 f"point) or in [6, 32]")

    def with_values(self, **values) -> "Injection":
        """A copy with some knobs changed; unknown names raise ValueError listing the known ones."""
        unknown = sorted(set(values) - set(self.FIELDS))
        if unknown:
            raise ValueError(f"unknown injection knob(s) {unknown}; known: {list(self.FIELDS)}")
        return replace(self, **values)

    def as_dict(self) -> dict:
        return {f.name: getattr(self, f.name) for f in fields(self)}
