"""A drive profile: which object of the drive under test carries each injection knob, and how.

The resource half of the drive (design.md §11, §12.4): the CiA 402 driver (``cia402``) is one;
what differs between drives is data, a TOML file (format: ``docs/drive-profile.md``) selected by
the bench file's ``[drive] profile``. For each knob the plans inject (``ia_offset_a``,
``dead_time_s``, ...) the profile names the object (index, sub-index), its CiA 301 data type,
its encoding (SI value = (count − ``zero_count``) / ``counts_per_si``) and how it is restored
(a ``[restore]`` object written once, or each knob written back to its ``restore`` count, by
default the EDS DefaultValue). A knob the profile leaves out is one the drive cannot inject;
``[fixed]`` states the value it runs at (from its documentation), else the shipped drive's
default is assumed. ``current_command`` names the object of the peak phase-current command;
without it the driver uses target torque 0x6071 (per mille of 0x6076, i.e. of the rated
current 0x6075).

The profile is checked against the drive's EDS when it is loaded (before any bus traffic): an
object missing from the EDS, a data type other than the profile's, a non-writable object, a
restore value or limit outside the type's or the EDS's range is an ``InputError`` of one line.
The shipped profile ``data/ripple_drive_profile.toml`` maps the shipped EDS; it is the default.
"""

from __future__ import annotations

import functools
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from canopen.objectdictionary import ODVariable

from hil.errors import InputError
from ripple_hil_drivers.canopen_eds import DEFAULT_EDS_PATH, ScaledObject, load_dictionary

DEFAULT_PROFILE_PATH = Path(__file__).resolve().parent / "data" / "ripple_drive_profile.toml"

#: CiA 301 numeric data types a knob may have: code -> (name, bits, signed).
NUMERIC_TYPES = {0x0001: ("BOOLEAN", 1, False), 0x0002: ("INTEGER8", 8, True),
                 0x0003: ("INTEGER16", 16, True), 0x0004: ("INTEGER32", 32, True),
                 0x0005: ("UNSIGNED8", 8, False), 0x0006: ("UNSIGNED16", 16, False),
                 0x0007: ("UNSIGNED32", 32, False), 0x0010: ("INTEGER24", 24, True),
                 0x0015: ("INTEGER64", 64, True), 0x0016: ("UNSIGNED24", 24, False),
                 0x001B: ("UNSIGNED64", 64, False)}
_WRITABLE = ("rw", "rww", "rwr", "wo")
_OBJECT_KEYS = {"index", "subindex", "type", "unit", "counts_per_si", "zero_count", "restore"}


@dataclass(frozen=True)
class RestoreObject:
    """One object that restores every knob to its default when ``value`` is written to it."""

    index: int
    subindex: int
    value: int


@dataclass(frozen=True)
class DriveProfile:
    """The knobs one drive can inject, as EDS objects; checked against ``eds_path``."""

    name: str
    source: Path
    eds_path: Path
    knobs: dict[str, ScaledObject]
    current_command: ScaledObject | None
    restore: RestoreObject | None
    fixed: dict[str, float] = field(default_factory=dict)

    def value_si(self, knob: str):
        """The knob's value when nothing is injected: the restore value of an injectable knob,
        the ``[fixed]`` value of one the drive lacks, else the shipped drive's default."""
        if knob in self.knobs:
            return self.knobs[knob].default_si
        if knob in self.fixed:
            return self.fixed[knob]
        return shipped_profile().knobs[knob].default_si

    def lacks(self, knob: str, value) -> bool:
        """True when the point needs ``knob`` = ``value`` and the drive cannot inject it (the
        value differs from the one it runs at)."""
        if knob in self.knobs:
            return False
        return not _same(value, self.value_si(knob))


def _same(a, b) -> bool:
    if isinstance(a, bool) or isinstance(b, bool):
        return bool(a) == bool(b)
    return math.isclose(float(a), float(b), rel_tol=1e-9, abs_tol=1e-12)


def plan_knobs() -> tuple[str, ...]:
    """Every injection knob the plans know (those of the shipped drive, which has them all)."""
    return tuple(shipped_profile().knobs)


def shipped_profile() -> DriveProfile:
    return load_profile(None, None)


def load_profile(profile_path: str | Path | None = None,
                 eds_path: str | Path | None = None) -> DriveProfile:
    """The profile at ``profile_path`` (None: the shipped one) checked against ``eds_path`` (None:
    the shipped EDS); ``InputError`` with one line naming the first problem."""
    return _load_cached(str(Path(profile_path or DEFAULT_PROFILE_PATH).resolve()),
                        str(Path(eds_path or DEFAULT_EDS_PATH).resolve()))


@functools.lru_cache(maxsize=16)
def _load_cached(profile_path: str, eds_path: str) -> DriveProfile:
    path = Path(profile_path)
    where = f"drive profile {path.name}"
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise InputError(f"{where}: cannot read it: {exc.strerror or exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{where}: not valid TOML: {exc}") from None
    unknown = set(data) - {"name", "current_command", "restore", "knobs", "fixed"}
    if unknown:
        raise InputError(f"{where}: unknown key(s) {sorted(unknown)}; allowed: name, "
                         "current_command, restore, knobs, fixed")
    try:
        od = load_dictionary(eds_path)
    except Exception as exc:  # noqa: BLE001 - canopen's parser raises many kinds
        raise InputError(f"{where}: cannot read the EDS {Path(eds_path).name}: {exc}") from None
    eds = f"the EDS {Path(eds_path).name}"
    known = None if path == DEFAULT_PROFILE_PATH.resolve() else set(plan_knobs())
    knobs = {}
    for knob, spec in (data.get("knobs") or {}).items():
        if known is not None and knob not in known:
            raise InputError(f"{where}: knobs.{knob} is not an injection knob of the plans "
                             f"(known: {', '.join(sorted(known))})")
        knobs[knob] = _scaled(od, knob, spec, f"{where}: knobs.{knob}", eds)
    command = data.get("current_command")
    command = None if command is None else _scaled(od, "current_command_a", command,
                                                   f"{where}: current_command", eds)
    fixed = {}
    for knob, value in (data.get("fixed") or {}).items():
        if known is not None and knob not in known or knob in knobs:
            raise InputError(f"{where}: fixed.{knob} is not a plan knob the profile leaves out")
        if not isinstance(value, (int, float)):
            raise InputError(f"{where}: fixed.{knob} = {value!r} is not a number")
        fixed[knob] = value
    return DriveProfile(name=str(data.get("name", path.stem)), source=path, eds_path=Path(eds_path),
                        knobs=knobs, current_command=command,
                        restore=_restore(od, data.get("restore"), f"{where}: restore", eds),
                        fixed=fixed)


def _variable(od, index, subindex, what: str, eds: str) -> ODVariable:
    if not isinstance(index, int) or not isinstance(subindex, int):
        raise InputError(f"{what}: index and subindex must be integers (e.g. index = 0x3000)")
    address = f"0x{index:04X}:{subindex:02X}"
    if index not in od:
        raise InputError(f"{what}: object {address} is not in {eds}")
    entry = od[index]
    if isinstance(entry, ODVariable):
        if subindex != 0:
            raise InputError(f"{what}: object {address}: 0x{index:04X} has no sub-indices in {eds}")
        return entry
    if subindex not in entry:
        raise InputError(f"{what}: object {address} is not in {eds}")
    return entry[subindex]


def _type_range(code: int) -> tuple[int, int]:
    _, bits, signed = NUMERIC_TYPES[code]
    return (-(1 << bits - 1), (1 << bits - 1) - 1) if signed else (0, (1 << bits) - 1)


def _scaled(od, knob: str, spec, what: str, eds: str) -> ScaledObject:
    if not isinstance(spec, dict):
        raise InputError(f"{what}: must be a table with index, type, unit, counts_per_si")
    unknown = set(spec) - _OBJECT_KEYS
    if unknown:
        raise InputError(f"{what}: unknown key(s) {sorted(unknown)}; allowed: "
                         f"{', '.join(sorted(_OBJECT_KEYS))}")
    missing = {"index", "type", "unit", "counts_per_si"} - set(spec)
    if missing:
        raise InputError(f"{what}: missing key(s) {sorted(missing)}")
    index, subindex = spec["index"], spec.get("subindex", 0)
    var = _variable(od, index, subindex, what, eds)
    address = f"0x{index:04X}:{subindex:02X}"
    eds_type = NUMERIC_TYPES.get(var.data_type, (f"0x{var.data_type:04X}",))[0]
    if spec["type"] != eds_type:
        raise InputError(f"{what}: object {address} is {eds_type} in {eds}, the profile says "
                         f"{spec['type']}")
    if var.data_type not in NUMERIC_TYPES:
        raise InputError(f"{what}: object {address} is {eds_type}, not an integer type")
    if var.access_type not in _WRITABLE or var.access_type == "wo":
        raise InputError(f"{what}: object {address} is '{var.access_type}' in {eds}; a knob must "
                         "be readable and writable (rw)")
    scale, zero = spec["counts_per_si"], spec.get("zero_count", 0)
    if isinstance(scale, bool) or not isinstance(scale, (int, float)) or not scale > 0 \
            or not math.isfinite(scale):
        raise InputError(f"{what}: counts_per_si = {scale!r} must be a positive number")
    if isinstance(zero, bool) or not isinstance(zero, int):
        raise InputError(f"{what}: zero_count = {zero!r} must be an integer")
    type_low, type_high = _type_range(var.data_type)
    low = type_low if var.min is None else int(var.min)
    high = type_high if var.max is None else int(var.max)
    if not type_low <= low <= high <= type_high:
        raise InputError(f"{what}: object {address} limits {low}..{high} in {eds} are outside "
                         f"its type {eds_type} ({type_low}..{type_high})")
    restore = spec.get("restore", var.default)
    if restore is None:
        raise InputError(f"{what}: object {address} has no DefaultValue in {eds}; state its "
                         "restore count in the profile")
    if isinstance(restore, bool) or not isinstance(restore, int) or not low <= restore <= high:
        raise InputError(f"{what}: restore value {restore!r} of object {address} is outside its "
                         f"range {low}..{high} in {eds}")
    return ScaledObject(knob=knob, index=index, subindex=subindex, unit=str(spec["unit"]),
                        counts_per_si=scale, zero_count=zero, data_type=eds_type,
                        low_count=low, high_count=high, default_count=restore)


def _restore(od, spec, what: str, eds: str) -> RestoreObject | None:
    if spec is None:
        return None
    if not isinstance(spec, dict) or set(spec) - {"index", "subindex", "value"} or "value" not in spec:
        raise InputError(f"{what}: must be a table with index, subindex and value")
    index, subindex, value = spec.get("index"), spec.get("subindex", 0), spec["value"]
    var = _variable(od, index, subindex, what, eds)
    address = f"0x{index:04X}:{subindex:02X}"
    if var.data_type not in NUMERIC_TYPES or var.access_type not in _WRITABLE:
        raise InputError(f"{what}: object {address} is not a writable integer in {eds}")
    low, high = _type_range(var.data_type)
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise InputError(f"{what}: value {value!r} does not fit object {address} "
                         f"({NUMERIC_TYPES[var.data_type][0]})")
    return RestoreObject(index=index, subindex=subindex, value=value)


def profile_for(drive_config) -> DriveProfile:
    """The profile a bench file's ``[drive]`` section selects (its ``profile`` and ``eds``)."""
    return load_profile(getattr(drive_config, "profile", None), drive_config.eds)
