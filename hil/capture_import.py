"""Captures from other DAQs: a CSV file or an ``.npz`` of named arrays, read into a Capture.

A scope or DAQ export names its columns its own way and in its own units. ``import_capture``
picks the time, torque and rotor-angle (or speed) columns by name, converts them to the SI
channels the analysis reads (``time_s``, ``torque_nm``, ``rotor_angle_mech_rad`` or
``speed_rpm``) and records where each came from in ``meta["imported"]``. CSV: one header row of
column names, then numbers; the delimiter (comma, semicolon, tab) is detected; lines starting with
``#`` are comments. An electrical angle column (``angle_kind="elec"``) is divided by the pole
pairs.
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


def read_columns(path: Path) -> dict[str, np.ndarray]:
    """Named 1-D columns of a CSV file or of an ``.npz`` archive of arrays."""
    if path.is_dir():
        raise InputError(f"{str(path)!r} is a directory, not a capture file")
    if not path.is_file():
        raise InputError(f"capture file {str(path)!r} does not exist")
    if zipfile.is_zipfile(path):
        try:
            with np.load(path, allow_pickle=False) as npz:
                columns = {name: np.asarray(npz[name]) for name in npz.files}
        except (OSError, ValueError, zipfile.BadZipFile) as exc:
            raise InputError(f"{str(path)!r} is not a readable .npz of numeric arrays "
                             f"({type(exc).__name__})") from None
        return {name: values for name, values in columns.items() if values.ndim == 1}
    return _read_csv(path)


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
                   time_unit: str = "s", torque_unit: str = "nm", angle_unit: str = "rad",
                   speed_unit: str = "rpm", angle_kind: str = "mech",
                   pole_pairs: int, ia_col: str | None = None, ib_col: str | None = None,
                   current_unit: str = "a") -> Capture:
    """A :class:`Capture` (SI channels, ``meta`` pole pairs and provenance) from a foreign file.

    Exactly one of ``angle_col`` (rotor angle) and ``speed_col`` (shaft speed) is needed.
    ``ia_col``/``ib_col``: the phase currents a and b (channels ``ia_a``, ``ib_a``), optional.
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
    channels = {"time_s": _column(columns, time_col, "--time-col")
                * _unit("time", TIME_UNITS, time_unit),
                "torque_nm": _column(columns, torque_col, "--torque-col")
                * _unit("torque", TORQUE_UNITS, torque_unit)}
    provenance = {"file": path.name, "time": f"{time_col} [{time_unit}]",
                  "torque": f"{torque_col} [{torque_unit}]"}
    if angle_col is not None:
        angle = _column(columns, angle_col, "--angle-col") * _unit("angle", ANGLE_UNITS,
                                                                   angle_unit)
        channels["rotor_angle_mech_rad"] = angle / pole_pairs if angle_kind == "elec" else angle
        provenance["angle"] = f"{angle_col} [{angle_unit}, {angle_kind}]"
    else:
        channels["speed_rpm"] = _column(columns, speed_col, "--speed-col") * _unit(
            "speed", SPEED_UNITS, speed_unit)
        provenance["speed"] = f"{speed_col} [{speed_unit}]"
    for column, channel in ((ia_col, "ia_a"), (ib_col, "ib_a")):
        if column is not None:
            channels[channel] = _column(columns, column, f"--{channel[:2]}-col") * _unit(
                "current", CURRENT_UNITS, current_unit)
            provenance[channel] = f"{column} [{current_unit}]"
    return Capture(channels=channels, meta={"pole_pairs": pole_pairs, "imported": provenance})


#: Column names tried, in order, when an import option does not name the column.
DEFAULT_COLUMNS = {"time_col": ("time_s", "time", "t", "t_s"),
                   "torque_col": ("torque_nm", "torque", "tau_m", "tau", "T_m"),
                   "angle_col": ("rotor_angle_mech_rad", "theta_m_rad", "theta_m", "theta_mech",
                                 "angle_mech_rad"),
                   "elec_angle_col": ("theta_e_rad", "theta_e", "rotor_angle_elec_rad"),
                   "ia_col": ("ia_a", "ia", "i_a"), "ib_col": ("ib_a", "ib", "i_b")}


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
