"""Per-capture operating points for captures that carry none: a TOML manifest
(``hil diagnose --manifest M.toml``) or ``FILE@CURRENT_A[,ANGLE_DEG]`` on the command line.

A capture recorded by ripple-hil sits in its record (``<record>/captures/``) and the record states
its operating point. A capture from another bench or simulator (a CSV or ``.npz`` export, read by
:mod:`hil.capture_import`), or one copied out of its record, needs it stated::

    [drive]                              # optional; overrides the bench file's values
    pole_pairs = 2
    emf_a_rising_zero_elec_deg = 180.0   # angle reference (hil/diagnosis/README.md); omit: unknown
    current_loop_bandwidth_hz = 1000.0   # the current loop: same keys as the bench file's [drive]
    ...
    [motor]                              # optional: the bench file's [motor] keys
    [[capture]]                          # one per file, path relative to the manifest
    file = "c500_20A.csv"
    current_a = 20.0                     # peak phase current amplitude, A
    current_angle_deg = 0.0              # optional, φ of paper eq 4
    torque_column = "torque_nm"          # import options (hil.capture_import), optional
    addition_ia_offset_a = 0.0           # a KNOWN addition made for this capture (issue 23 item 1)

Every key is checked against the allowed ones (a misspelled key names the allowed keys), a file
listed twice and a current ≤ 0 are refused.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field, fields
from pathlib import Path

from hil.errors import InputError
from hil.motor import MotorParameters

#: [drive] keys: the angle reference, PWM, transducer, and the bench file's current-loop keys.
DRIVE_FLOAT_KEYS = ("emf_a_rising_zero_elec_deg", "emf_a_rising_zero_u_elec_deg",
                    "pwm_frequency_hz", "transducer_bandwidth_hz", "current_loop_bandwidth_hz",
                    "current_loop_delay_s", "current_loop_delay_periods", "dead_time_bound_s",
                    "current_channel_u_a")
DRIVE_BOOL_KEYS = ("current_loop_decoupling", "current_loop_emf_feedforward",
                   "current_loop_angle_compensation")
#: current_loop_design values: those the fit's DriveSetup knows (hil.diagnosis.signatures
#: LOOP_DESIGNS when it states them), else the bench file's two and "unknown".
LOOP_DESIGNS = ("continuous", "discrete", "unknown")


def loop_designs() -> tuple[str, ...]:
    from hil.diagnosis import signatures

    return tuple(getattr(signatures, "LOOP_DESIGNS", LOOP_DESIGNS))
DRIVE_KEYS = ("pole_pairs", "encoder_counts_per_rev", "current_loop_design") + DRIVE_FLOAT_KEYS \
    + DRIVE_BOOL_KEYS
MOTOR_KEYS = tuple(f.name for f in fields(MotorParameters))
#: Known additions (shared contract of issue 23): operating-point keys, default 0.
ADDITION_KEYS = ("addition_ia_offset_a", "addition_ib_offset_a", "addition_gain_a_pu",
                 "addition_dead_time_s")
#: [[capture]] import options → keyword of :func:`hil.capture_import.import_capture`.
IMPORT_KEYS = {"time_column": "time_col", "torque_column": "torque_col",
               "angle_column": "angle_col", "speed_column": "speed_col",
               "ia_column": "ia_col", "ib_column": "ib_col", "time_unit": "time_unit",
               "torque_unit": "torque_unit", "angle_unit": "angle_unit",
               "speed_unit": "speed_unit", "current_unit": "current_unit",
               "angle_kind": "angle_kind"}
CAPTURE_KEYS = ("file", "current_a", "current_angle_deg", "label",
                "emf_a_rising_zero_elec_deg") + tuple(IMPORT_KEYS) + ADDITION_KEYS
TOP_KEYS = ("drive", "motor", "capture")


@dataclass(frozen=True)
class CaptureEntry:
    """One capture file and what is stated about it.

    ``operating_point``: ``current_a`` (peak phase current, A), ``current_angle_rad`` when stated,
    ``label``, the four ``addition_*`` keys (always present, 0 when not stated) and
    ``emf_a_rising_zero_elec_deg`` when stated for this capture. ``import_options``: keywords of
    :func:`hil.capture_import.import_capture` (column names and units) as stated.
    """

    path: Path
    operating_point: dict
    import_options: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Manifest:
    """A parsed manifest: ``drive`` and ``motor`` hold only the keys stated."""

    path: Path | None
    drive: dict
    motor: dict
    captures: tuple[CaptureEntry, ...]

    @property
    def emf_a_rising_zero_elec_deg(self) -> float | None:
        return self.drive.get("emf_a_rising_zero_elec_deg")

    @property
    def pole_pairs(self) -> int | None:
        if "pole_pairs" in self.drive:
            return self.drive["pole_pairs"]
        if "pole_count" in self.motor:
            return self.motor["pole_count"] // 2
        return None


def _unknown_keys(table: dict, allowed: tuple, where: str) -> None:
    unknown = sorted(set(table) - set(allowed))
    if unknown:
        raise InputError(f"{where}: unknown key(s) {', '.join(map(repr, unknown))} (allowed: "
                         f"{', '.join(allowed)})")


def _number(value, key: str, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise InputError(f"{where}: {key} = {value!r} must be a finite number")
    return float(value)


def _current(value, where: str) -> float:
    current = _number(value, "current_a", where)
    if not 0 < current <= 100:
        raise InputError(f"{where}: current_a = {value!r} must be a peak phase current in "
                         "(0, 100] A")
    return current


def _parse_drive(table, where: str) -> dict:
    if not isinstance(table, dict):
        raise InputError(f"{where}: [drive] must be a table")
    _unknown_keys(table, DRIVE_KEYS, f"{where} [drive]")
    out = {}
    for key, value in table.items():
        if key in ("pole_pairs", "encoder_counts_per_rev"):
            top = 100 if key == "pole_pairs" else 10 ** 9
            if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= top:
                raise InputError(f"{where} [drive]: {key} = {value!r} must be an integer "
                                 f"1..{top}")
            out[key] = value
        elif key == "current_loop_design":
            if value not in loop_designs():
                raise InputError(f"{where} [drive]: current_loop_design = {value!r} is not one "
                                 f"of {', '.join(loop_designs())}")
            out[key] = value
        elif key in DRIVE_BOOL_KEYS:
            if not isinstance(value, bool):
                raise InputError(f"{where} [drive]: {key} = {value!r} must be true or false")
            out[key] = value
        else:
            out[key] = _number(value, key, f"{where} [drive]")
    return out


def _parse_motor(table, where: str) -> dict:
    if not isinstance(table, dict):
        raise InputError(f"{where}: [motor] must be a table")
    _unknown_keys(table, MOTOR_KEYS, f"{where} [motor]")
    try:
        MotorParameters(**table)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{where} [motor]: {exc}") from None
    return dict(table)


def _parse_capture(entry, index: int, base: Path, where: str) -> CaptureEntry:
    at = f"{where} [[capture]] #{index + 1}"
    if not isinstance(entry, dict):
        raise InputError(f"{at}: each [[capture]] must be a table")
    _unknown_keys(entry, CAPTURE_KEYS, at)
    if "file" not in entry or not isinstance(entry["file"], str) or not entry["file"]:
        raise InputError(f"{at}: file = \"...\" (the capture's path, relative to the manifest) "
                         "is required")
    at = f"{where} [[capture]] file = {entry['file']!r}"
    if "current_a" not in entry:
        raise InputError(f"{at}: current_a (peak phase current commanded, A) is required")
    op = {"current_a": _current(entry["current_a"], at),
          "label": str(entry.get("label") or Path(entry["file"]).stem)}
    if "current_angle_deg" in entry:
        op["current_angle_rad"] = math.radians(_number(entry["current_angle_deg"],
                                                       "current_angle_deg", at))
    if "emf_a_rising_zero_elec_deg" in entry:
        op["emf_a_rising_zero_elec_deg"] = _number(entry["emf_a_rising_zero_elec_deg"],
                                                   "emf_a_rising_zero_elec_deg", at)
    for key in ADDITION_KEYS:
        op[key] = _number(entry.get(key, 0.0), key, at)
    options = {}
    for key, keyword in IMPORT_KEYS.items():
        if key in entry:
            if not isinstance(entry[key], str) or not entry[key]:
                raise InputError(f"{at}: {key} = {entry[key]!r} must be a non-empty string")
            options[keyword] = entry[key]
    path = Path(entry["file"])
    return CaptureEntry(path=path if path.is_absolute() else base / path, operating_point=op,
                        import_options=options)


def check_distinct(entries) -> None:
    """Refuse a capture file listed twice (it would count its evidence twice)."""
    seen: dict[Path, str] = {}
    for entry in entries:
        key = entry.path.resolve()
        if key in seen:
            raise InputError(f"capture file {str(entry.path)!r} is listed twice (also as "
                             f"{seen[key]!r}); each capture counts once")
        seen[key] = str(entry.path)


def parse_manifest(text: str, path: Path | None = None) -> Manifest:
    """A :class:`Manifest` from TOML text; paths are relative to ``path``'s folder."""
    where = str(path) if path else "manifest"
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{where}: not valid TOML ({exc})") from None
    _unknown_keys(data, TOP_KEYS, where)
    base = path.parent if path else Path.cwd()
    drive = _parse_drive(data.get("drive", {}), where)
    motor = _parse_motor(data.get("motor", {}), where)
    if "pole_pairs" in drive and "pole_count" in motor and motor["pole_count"] != \
            2 * drive["pole_pairs"]:
        raise InputError(f"{where}: [drive] pole_pairs = {drive['pole_pairs']} and [motor] "
                         f"pole_count = {motor['pole_count']} disagree")
    entries = data.get("capture", [])
    if not isinstance(entries, list) or not entries:
        raise InputError(f"{where}: no [[capture]] entries (one per capture file: file = ..., "
                         "current_a = ...)")
    captures = tuple(_parse_capture(e, i, base, where) for i, e in enumerate(entries))
    check_distinct(captures)
    return Manifest(path=path, drive=drive, motor=motor, captures=captures)


def load_manifest(path: str | Path) -> Manifest:
    path = Path(path)
    if not path.is_file():
        raise InputError(f"manifest {str(path)!r} does not exist")
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"manifest {str(path)!r} is not readable text ({type(exc).__name__})") \
            from None
    return parse_manifest(text, path)


def parse_capture_argument(text: str) -> CaptureEntry:
    """``FILE``, ``FILE@CURRENT_A`` or ``FILE@CURRENT_A,ANGLE_DEG`` (peak phase current in A,
    current angle φ in electrical degrees). A file name that itself contains ``@`` is taken as is
    when it exists."""
    if "@" not in text or Path(text).exists():
        return CaptureEntry(path=Path(text), operating_point={})
    name, _, spec = text.rpartition("@")
    parts = spec.split(",")
    try:
        values = [float(part) for part in parts]
    except ValueError:
        values = []
    if not name or not 1 <= len(values) <= 2 or len(values) != len(parts):
        raise InputError(f"{text!r}: write a capture with its operating point as "
                         "FILE@CURRENT_A or FILE@CURRENT_A,ANGLE_DEG (e.g. c.csv@20 or "
                         "c.csv@20,15)")
    op = {"current_a": _current(values[0], text), "label": Path(name).stem}
    if len(values) == 2:
        op["current_angle_rad"] = math.radians(_number(values[1], "ANGLE_DEG", text))
    op.update({key: 0.0 for key in ADDITION_KEYS})
    return CaptureEntry(path=Path(name), operating_point=op)
