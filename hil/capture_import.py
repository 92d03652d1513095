"""Captures from other DAQs: a CSV file, an ``.npz`` of named arrays, an ASAM MDF4 file
(:mod:`hil.capture_mdf`) or an NI TDMS file (:mod:`hil.capture_tdms`), read into a Capture.

A scope or DAQ export names its columns its own way and in its own units. ``import_capture``
picks the time, torque and rotor-angle (or speed) columns by name, converts them to the SI
channels the analysis reads (``time_s``, ``torque_nm``, ``rotor_angle_mech_rad`` or
``speed_rpm``) and records where each came from in ``meta["imported"]``. CSV: one header row of
column names, then numbers; the delimiter (comma, semicolon, tab) is detected; lines starting with
``#`` are comments. An electrical angle column (``angle_kind="elec"``) is divided by the pole
pairs. MDF4 and TDMS files state each channel's unit: a unit option left unset takes the file's
(``N·m``, ``mNm``, ``°``, ``1/min``… spelled as :func:`unit_key` accepts), one that contradicts
the file is refused; the columns of one capture must come from one channel group (one rate).
"""

from __future__ import annotations

import csv
import io
import math
import zipfile
from pathlib import Path

import numpy as np

from hil.capture import Capture
from hil.errors import InputError

#: Unit name → factor to SI, per quantity.
TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
ANGLE_UNITS = {"rad": 1.0, "deg": math.pi / 180.0, "rev": 2.0 * math.pi}
TORQUE_UNITS = {"nm": 1.0, "mnm": 1e-3, "ncm": 1e-2, "kgfm": 9.80665, "lbfin": 0.1129848290276167,
                "lbfft": 1.3558179483314004, "ozfin": 0.007061551814226}
SPEED_UNITS = {"rpm": 1.0, "rad/s": 60.0 / (2.0 * math.pi), "hz": 60.0}
CURRENT_UNITS = {"a": 1.0, "ma": 1e-3}
ANGLE_KINDS = ("mech", "elec")


def _unit(kind: str, table: dict[str, float], unit: str) -> float:
    try:
        return table[unit.lower()]
    except KeyError:
        raise InputError(f"{kind} unit {unit!r} is not known (allowed: {', '.join(table)})") \
            from None


#: Spellings of a unit in measurement files -> the key of the unit tables above.
_SPELLINGS = {"°": "deg", "degree": "deg", "degrees": "deg", "1/min": "rpm", "min-1": "rpm",
              "min^-1": "rpm", "u/min": "rpm", "r/min": "rpm", "sec": "s", "µs": "us",
              "μs": "us", "rad/sec": "rad/s"}


def unit_key(kind: str, table: dict[str, float], text: str) -> str:
    """The table key of a unit as a file spells it (``N·m``, ``N*m``, ``N m`` → ``nm``,
    ``mN·m`` → ``mnm``, ``°`` → ``deg``, ``1/min`` → ``rpm``); an unknown one is named."""
    key = text.strip().lower()
    for mark in ("·", "*", " ", ".", "⋅"):
        key = key.replace(mark, "")
    key = _SPELLINGS.get(key, key)
    if key not in table:
        raise InputError(f"{kind} unit {text!r} (as the file states it) is not known (allowed: "
                         f"{', '.join(table)})")
    return key


class ColumnTable(dict):
    """Named 1-D columns (a dict) with the units a file states (``units``, "" where it states
    none) and the channel group each came from (``groups``; empty for CSV and npz)."""

    def __init__(self, columns, units=None, groups=None) -> None:
        super().__init__(columns)
        self.units: dict[str, str] = dict(units or {})
        self.groups: dict[str, int] = dict(groups or {})


def read_columns(path: Path) -> ColumnTable:
    """Named 1-D columns of a CSV file, an ``.npz`` archive of arrays, an MDF4 or a TDMS file."""
    from hil.capture_mdf import is_mdf, read_mdf
    from hil.capture_tdms import is_tdms, read_tdms

    if path.is_dir():
        raise InputError(f"{str(path)!r} is a directory, not a capture file")
    if not path.is_file():
        raise InputError(f"capture file {str(path)!r} does not exist")
    if is_mdf(path):
        return ColumnTable(*read_mdf(path))
    if is_tdms(path):
        return ColumnTable(*read_tdms(path))
    if zipfile.is_zipfile(path):
        try:
            with np.load(path, allow_pickle=False) as npz:
                columns = {name: np.asarray(npz[name]) for name in npz.files}
        except (OSError, ValueError, zipfile.BadZipFile) as exc:
            raise InputError(f"{str(path)!r} is not a readable .npz of numeric arrays "
                             f"({type(exc).__name__})") from None
        return ColumnTable({name: values for name, values in columns.items()
                            if values.ndim == 1})
    return ColumnTable(_read_csv(path))


def _read_csv(path: Path) -> dict[str, np.ndarray]:
    try:
        text = path.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{str(path)!r} is neither an .npz archive nor a text CSV file "
                         f"({type(exc).__name__})") from None
    lines = [line for line in text.splitlines() if line.strip() and not line.startswith("#")]
    if len(lines) < 2:
        raise InputError(f"CSV file {str(path)!r} needs a header row and at least one data row")
    try:
        dialect = csv.Sniffer().sniff(lines[0], delimiters=",;\t")
    except csv.Error:
        raise InputError(f"CSV file {str(path)!r}: no comma, semicolon or tab between the "
                         "column names of its header row") from None
    rows = list(csv.reader(io.StringIO("\n".join(lines)), dialect))
    header = [name.strip() for name in rows[0]]
    try:
        data = np.array([[float(cell) for cell in row] for row in rows[1:]], dtype=float)
    except ValueError as exc:
        raise InputError(f"CSV file {str(path)!r}: a data cell is not a number ({exc})") from None
    if data.ndim != 2 or data.shape[1] != len(header):
        raise InputError(f"CSV file {str(path)!r}: every row needs {len(header)} values "
                         f"(one per column of the header)")
    return {name: data[:, index] for index, name in enumerate(header)}


def _column(columns: dict[str, np.ndarray], name: str, option: str) -> np.ndarray:
    if name not in columns:
        raise InputError(f"{option} {name!r}: no such column (the file has: "
                         f"{', '.join(sorted(columns)) or 'no 1-D columns'})")
    return np.asarray(columns[name], dtype=float)


def import_capture(path: str | Path, *, time_col: str, torque_col: str,
                   angle_col: str | None = None, speed_col: str | None = None,
                   time_unit: str | None = None, torque_unit: str | None = None,
                   angle_unit: str | None = None, speed_unit: str | None = None,
                   angle_kind: str = "mech",
                   pole_pairs: int, ia_col: str | None = None, ib_col: str | None = None,
                   current_unit: str | None = None) -> Capture:
    """A :class:`Capture` (SI channels, ``meta`` pole pairs and provenance) from a foreign file.

    Exactly one of ``angle_col`` (rotor angle) and ``speed_col`` (shaft speed) is needed.
    ``ia_col``/``ib_col``: the phase currents a and b (channels ``ia_a``, ``ib_a``), optional.
    A unit left None is the one the file states for that column, else s, N·m, rad, rpm, A.
    """
    if (angle_col is None) == (speed_col is None):
        raise InputError("give the rotor angle (--angle-col) or the speed (--speed-col), one of "
                         "them (allowed: exactly one)")
    if angle_kind not in ANGLE_KINDS:
        raise InputError(f"angle kind {angle_kind!r} is not one of {', '.join(ANGLE_KINDS)}")
    if isinstance(pole_pairs, bool) or not isinstance(pole_pairs, int) or not 1 <= pole_pairs <= 100:
        raise InputError(f"--pole-pairs must be an integer 1..100 for an imported capture, "
                         f"got {pole_pairs!r}")
    path = Path(path)
    columns = read_columns(path)
    named = {"--time-col": time_col, "--torque-col": torque_col, "--angle-col": angle_col,
             "--speed-col": speed_col, "--ia-col": ia_col, "--ib-col": ib_col}
    for option, name in named.items():
        if name is not None:
            _column(columns, name, option)
    _one_group(columns, [name for name in named.values() if name is not None], path)
    channels, provenance = {}, {"file": path.name}

    def take(option, name, kind, table, given, default):
        """The column in SI units, and the unit it was read in."""
        unit = _file_unit(columns, name, kind, table, given, default)
        return _column(columns, name, option) * table[unit], unit

    channels["time_s"], unit = take("--time-col", time_col, "time", TIME_UNITS, time_unit, "s")
    provenance["time"] = f"{time_col} [{unit}]"
    channels["torque_nm"], unit = take("--torque-col", torque_col, "torque", TORQUE_UNITS,
                                       torque_unit, "nm")
    provenance["torque"] = f"{torque_col} [{unit}]"
    if angle_col is not None:
        angle, unit = take("--angle-col", angle_col, "angle", ANGLE_UNITS, angle_unit, "rad")
        channels["rotor_angle_mech_rad"] = angle / pole_pairs if angle_kind == "elec" else angle
        provenance["angle"] = f"{angle_col} [{unit}, {angle_kind}]"
    else:
        channels["speed_rpm"], unit = take("--speed-col", speed_col, "speed", SPEED_UNITS,
                                           speed_unit, "rpm")
        provenance["speed"] = f"{speed_col} [{unit}]"
    for column, channel in ((ia_col, "ia_a"), (ib_col, "ib_a")):
        if column is not None:
            channels[channel], unit = take(f"--{channel[:2]}-col", column, "current",
                                           CURRENT_UNITS, current_unit, "a")
            provenance[channel] = f"{column} [{unit}]"
    return Capture(channels=channels, meta={"pole_pairs": pole_pairs, "imported": provenance})


def _file_unit(columns: ColumnTable, name: str, kind: str, table: dict[str, float],
               given: str | None, default: str) -> str:
    """The unit of column ``name``: the one given (checked against the file's), else the file's,
    else ``default``."""
    stated = columns.units.get(name, "")
    from_file = unit_key(kind, table, stated) if stated else None
    if given is None:
        return from_file or default
    given_key = _unit_key_given(kind, table, given)
    if from_file is not None and from_file != given_key:
        raise InputError(f"{kind} unit {given!r} was given for column {name!r}, but the file "
                         f"states {stated!r}; leave the unit option out to use the file's")
    return given_key


def _unit_key_given(kind: str, table: dict[str, float], unit: str) -> str:
    _unit(kind, table, unit)
    return unit.lower()


def _one_group(columns: ColumnTable, names: list[str], path: Path) -> None:
    """Refuse columns from different channel groups (MDF/TDMS groups sample at their own rate)."""
    groups = {name: columns.groups[name] for name in names if name in columns.groups}
    if len(set(groups.values())) > 1:
        listed = ", ".join(f"{name} (group {group})" for name, group in groups.items())
        raise InputError(f"{str(path)!r}: the columns {listed} come from different channel "
                         "groups (each group has its own time base); resample them into one "
                         "group in the measurement tool, or pick columns of one group")


#: Column names tried, in order, when an import option does not name the column.
DEFAULT_COLUMNS = {"time_col": ("time_s", "time", "t", "t_s"),
                   "torque_col": ("torque_nm", "torque", "tau_m", "tau", "T_m"),
                   "angle_col": ("rotor_angle_mech_rad", "theta_m_rad", "theta_m", "theta_mech",
                                 "angle_mech_rad"),
                   "elec_angle_col": ("theta_e_rad", "theta_e", "rotor_angle_elec_rad"),
                   "ia_col": ("ia_a", "ia", "i_a"), "ib_col": ("ib_a", "ib", "i_b")}


def is_measurement_file(path: Path) -> bool:
    """True for an MDF4 or TDMS file (they name their channels and units themselves)."""
    from hil.capture_mdf import is_mdf
    from hil.capture_tdms import is_tdms

    return Path(path).is_file() and (is_mdf(Path(path)) or is_tdms(Path(path)))


def is_ripple_hil_capture(path: Path) -> bool:
    """True for a capture file written by :meth:`hil.capture.Capture.save`."""
    if not path.is_file() or not zipfile.is_zipfile(path):
        return False
    try:
        with zipfile.ZipFile(path) as archive:
            return "__header__.npy" in archive.namelist()
    except (OSError, zipfile.BadZipFile):
        return False


def import_with_defaults(path: str | Path, *, pole_pairs: int, **options) -> Capture:
    """:func:`import_capture` with the columns that ``options`` does not name found by their
    usual names (:data:`DEFAULT_COLUMNS`); a missing torque or angle column is named."""
    path = Path(path)
    columns = read_columns(path)
    have = ", ".join(sorted(columns)) or "no 1-D columns"

    def pick(option: str) -> str | None:
        return next((name for name in DEFAULT_COLUMNS[option] if name in columns), None)

    options = dict(options)
    for option, what in (("time_col", "time"), ("torque_col", "torque")):
        if option not in options:
            options[option] = pick(option)
            if options[option] is None:
                key = "time_column" if option == "time_col" else "torque_column"
                raise InputError(f"{str(path)!r}: no {what} column (tried "
                                 f"{', '.join(DEFAULT_COLUMNS[option])}; the file has: {have}); "
                                 f"name it with {key} = \"...\" in the manifest")
    if "angle_col" not in options and "speed_col" not in options:
        if pick("angle_col"):
            options["angle_col"] = pick("angle_col")
        elif pick("elec_angle_col"):
            options["angle_col"], options["angle_kind"] = pick("elec_angle_col"), "elec"
        else:
            tried = DEFAULT_COLUMNS["angle_col"] + DEFAULT_COLUMNS["elec_angle_col"]
            raise InputError(f"{str(path)!r}: no rotor-angle column (tried {', '.join(tried)}"
                             f"; the file has: {have}); the diagnosis needs the rotor angle "
                             "(the torque's phase is referred to it): name it with "
                             "angle_column = \"...\" and angle_kind = \"mech\" or \"elec\"")
    for option in ("ia_col", "ib_col"):
        if option not in options and pick(option):
            options[option] = pick(option)
    return import_capture(path, pole_pairs=pole_pairs, **options)


def check_torque(capture: Capture, name: str) -> None:
    """Refuse a capture whose torque channel is missing or holds NaN/inf samples, saying how
    many and where."""
    if "torque_nm" not in capture:
        raise InputError(f"{name}: no torque channel 'torque_nm' (channels: "
                         f"{', '.join(sorted(capture.channels))})")
    torque = np.asarray(capture["torque_nm"], dtype=float)
    bad = ~np.isfinite(torque)
    if bad.any():
        index = np.flatnonzero(bad)
        column = (capture.meta.get("imported") or {}).get("torque", "torque_nm")
        where = f"sample {index[0]}" + (f" (t = {float(capture['time_s'][index[0]]):.6g} s)"
                                         if "time_s" in capture else "")
        raise InputError(f"{name}: torque column {column} has {index.size} NaN/inf sample(s) of "
                         f"{torque.size}, the first at {where}, the last at sample {index[-1]}; "
                         "export the capture without gaps (or cut it to a span without them)")
