"""The shipped drive EDS (CiA 306) and the fault-injection objects it describes.

``drivers/data/ripple_drive.eds`` is the object dictionary of the shipped (simulated) drive. Its
fault-injection objects follow a naming convention, kept as documentation inside the EDS: each
knob of the plans is one manufacturer-specific object in 0x2001..0x20FF whose ParameterName is
``"<knob name> [<unit>]"``. Which object of a drive carries which knob, and how it scales, is
not read from these names by the driver: that is the drive profile
(``ripple_hil_drivers.drive_profile``, ``docs/drive-profile.md``); the shipped profile
``drivers/data/ripple_drive_profile.toml`` states the same mapping as these names (a test keeps
the two equal). Units of the names, i.e. the fixed-point encoding of the integer on the bus:

========  ====================  =============================================
unit      SI value per count    knobs
========  ====================  =============================================
mA        1e-3 A                ia_offset_a, ib_offset_a, current_command_a, loop_test_amplitude_a
ppm       1e-6 per unit         ia_gain_error_pu, ib_gain_error_pu (per unit of the nominal gain)
ns        1e-9 s                dead_time_s
urad      1e-6 rad              current_angle_rad
counts    1                     encoder_decimation, pwm_period_counts
order     1                     loop_test_order (electrical order of the loop's test signal)
bits      1                     word_length_bits
Hz        1                     pwm_frequency_hz
bool      0 / 1                 hall_mode
========  ====================  =============================================

Values are rounded to the nearest count before sending, so ``injection()`` reads back the
quantised value. Object 0x2000 restores every knob to its default when the CiA 301 "load"
signature 0x64616F6C is written to it.
"""

from __future__ import annotations

import functools
import math
import re
from dataclasses import dataclass
from pathlib import Path

import canopen

DEFAULT_EDS_PATH = Path(__file__).resolve().parent / "data" / "ripple_drive.eds"

RESTORE_DEFAULTS_INDEX = 0x2000
RESTORE_SIGNATURE = 0x64616F6C  # "load" read as a little-endian UNSIGNED32 (CiA 301, 0x1011)
CURRENT_COMMAND_INDEX = 0x2100
INJECTION_INDEX_RANGE = range(0x2001, 0x2100)

COUNTS_PER_SI_UNIT = {"mA": 1000, "ppm": 1_000_000, "ns": 1_000_000_000, "urad": 1_000_000,
                      "counts": 1, "bits": 1, "Hz": 1, "bool": 1, "order": 1}

_NAME_PATTERN = re.compile(r"^(?P<knob>[a-z0-9_]+) \[(?P<unit>[A-Za-z]+)\]$")


@dataclass(frozen=True)
class ScaledObject:
    """One EDS object holding an SI quantity as a scaled integer (value_si = count / counts_per_si)."""

    knob: str
    index: int
    unit: str
    counts_per_si: float
    low_count: int
    high_count: int
    default_count: int
    subindex: int = 0
    #: the count that encodes SI zero (e.g. 32768 for a Q15 gain trim whose nominal gain is 1.0)
    zero_count: int = 0
    data_type: str = ""

    @property
    def is_bool(self) -> bool:
        return self.unit == "bool"

    @property
    def is_integer(self) -> bool:
        """True when the SI value itself is an integer (counts, bits, Hz)."""
        return self.counts_per_si == 1 and not self.is_bool

    def to_count(self, value_si: float | bool | int) -> int:
        """Encode an SI value as the integer sent on the bus (nearest count)."""
        if self.is_bool:
            return int(bool(value_si))
        return int(round(float(value_si) * self.counts_per_si)) + self.zero_count

    def to_si(self, count: int) -> float | int | bool:
        """Decode a bus integer into its SI value."""
        if self.is_bool:
            return bool(count)
        if self.is_integer:
            return int(count) - self.zero_count
        return (count - self.zero_count) / self.counts_per_si

    @property
    def low_si(self):
        return self.to_si(self.low_count)

    @property
    def high_si(self):
        return self.to_si(self.high_count)

    @property
    def default_si(self):
        return self.to_si(self.default_count)

    @property
    def address(self) -> str:
        """``0x2001`` (sub-index 0) or ``0x3000:01``."""
        return f"0x{self.index:04X}" + (f":{self.subindex:02X}" if self.subindex else "")

    def range_text(self) -> str:
        return f"{self.low_si:g}..{self.high_si:g}"

    def check_si(self, value_si) -> int:
        """Return the count for ``value_si`` or raise ValueError naming the knob and its range."""
        if isinstance(value_si, bool) and not self.is_bool:
            raise ValueError(f"{self.knob}: expected a number, got {value_si!r}")
        try:
            as_float = float(value_si)
        except (TypeError, ValueError):
            raise ValueError(f"{self.knob}: expected a number, got {value_si!r}") from None
        if not math.isfinite(as_float):
            raise ValueError(f"{self.knob}={value_si!r} is outside {self.range_text()}")
        if self.is_integer and as_float != int(as_float):
            raise ValueError(f"{self.knob}={value_si!r} must be an integer in {self.range_text()}")
        count = self.to_count(value_si)
        if not self.low_count <= count <= self.high_count:
            raise ValueError(f"{self.knob}={value_si!r} is outside {self.range_text()} "
                             f"(EDS object {self.address})")
        return count


def parse_scaled_name(name: str) -> tuple[str, str] | None:
    """Split an EDS ParameterName ``"knob [unit]"`` into (knob, unit); None if it is not one."""
    match = _NAME_PATTERN.match(name)
    if match is None or match["unit"] not in COUNTS_PER_SI_UNIT:
        return None
    return match["knob"], match["unit"]


def _scaled_object(variable) -> ScaledObject:
    parsed = parse_scaled_name(variable.name)
    if parsed is None:
        raise ValueError(f"EDS object 0x{variable.index:04X} name {variable.name!r} is not "
                         f"'<knob> [<unit>]' with a unit in {sorted(COUNTS_PER_SI_UNIT)}")
    knob, unit = parsed
    if variable.min is None or variable.max is None or variable.default is None:
        raise ValueError(f"EDS object 0x{variable.index:04X} ({knob}) needs LowLimit, HighLimit "
                         f"and DefaultValue")
    return ScaledObject(knob=knob, index=variable.index, unit=unit, counts_per_si=COUNTS_PER_SI_UNIT[unit],
                        low_count=int(variable.min), high_count=int(variable.max),
                        default_count=int(variable.default))


def load_dictionary(eds_path: str | Path | None = None, node_id: int | None = None):
    """Parse the EDS into a fresh ``canopen.ObjectDictionary`` (one per node: they are mutable)."""
    return canopen.import_od(str(eds_path or DEFAULT_EDS_PATH), node_id)


@functools.lru_cache(maxsize=8)
def _injection_objects_cached(eds_path: str) -> tuple[ScaledObject, ...]:
    od = load_dictionary(eds_path)
    return tuple(_scaled_object(od[index]) for index in INJECTION_INDEX_RANGE if index in od)


def injection_objects(eds_path: str | Path | None = None) -> dict[str, ScaledObject]:
    """The fault-injection knobs described by the EDS, by knob name, in index order."""
    objects = _injection_objects_cached(str(eds_path or DEFAULT_EDS_PATH))
    return {obj.knob: obj for obj in objects}


def current_command_object(eds_path: str | Path | None = None) -> ScaledObject:
    """Object 0x2100, the peak phase-current command (``current_command_a [mA]``)."""
    return _scaled_object(load_dictionary(eds_path)[CURRENT_COMMAND_INDEX])


def object_table_markdown(eds_path: str | Path | None = None) -> str:
    """A Markdown table of the drive's command and fault-injection objects, rendered from the EDS.

    The documentation of the drive profile is generated from here, so it cannot drift from
    what the driver and the simulated drive use.
    """
    rows = ["| index | knob | bus unit | SI range | default |", "|---|---|---|---|---|"]
    objects = list(injection_objects(eds_path).values()) + [current_command_object(eds_path)]
    for obj in objects:
        rows.append(f"| 0x{obj.index:04X} | `{obj.knob}` | {obj.unit} | {obj.range_text()} | "
                    f"{obj.default_si!r} |")
    rows.append(f"| 0x{RESTORE_DEFAULTS_INDEX:04X} | restore injection defaults | write "
                f"0x{RESTORE_SIGNATURE:08X} (\"load\") | | |")
    return "\n".join(rows)
