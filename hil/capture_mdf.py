"""ASAM MDF4 measurement files (``.mf4``, read and written with asammdf), in and out.

In: every channel group's channels by name with the unit the file states, and each group's
master (time) channel under its own name, so ``hil analyze``/``hil diagnose`` import a CANape,
INCA or vSignalyzer measurement like a CSV (:mod:`hil.capture_import`). Out: one capture as an
MDF 4.10 file, one channel group whose master is ``time_s`` [s] and whose channels carry the
capture's units; the header names the record it came from (its id, software version and git SHA,
the capture's SHA-256 in the record, the test id) in its XML comment's ``common_properties``.
"""

from __future__ import annotations

import json
from pathlib import Path
from xml.sax.saxutils import escape, quoteattr

import numpy as np

from hil.capture import Capture
from hil.errors import InputError

#: First 8 bytes of every MDF file (ASAM MDF 4.x identification block).
MAGIC = b"MDF     "


def is_mdf(path: Path) -> bool:
    """True for a file that starts with the MDF identification block."""
    try:
        with open(path, "rb") as handle:
            return handle.read(8) == MAGIC
    except OSError:
        return False


def read_mdf(path: Path) -> tuple[dict[str, np.ndarray], dict[str, str], dict[str, int]]:
    """(columns, units, channel group of each column) of an MDF file.

    A name found in more than one group is kept from the first group that has it (MDF names
    need not be unique; asammdf's ``get`` asks for the group then). Non-numeric and
    multi-dimensional channels are left out.
    """
    from asammdf import MDF

    try:
        mdf = MDF(str(path))
    except Exception as exc:  # noqa: BLE001 - asammdf raises many kinds on a damaged file
        raise InputError(f"{str(path)!r} is not a readable MDF file "
                         f"({type(exc).__name__}: {exc})") from None
    columns: dict[str, np.ndarray] = {}
    units: dict[str, str] = {}
    groups: dict[str, int] = {}
    try:
        for index, group in enumerate(mdf.groups):
            master = mdf.masters_db.get(index)
            for number, channel in enumerate(group.channels):
                if channel.name in columns:
                    continue
                signal = mdf.get(group=index, index=number, raw=False)
                samples = np.asarray(signal.samples)
                if number == master:
                    samples = np.asarray(signal.timestamps)
                if samples.ndim != 1 or samples.dtype.kind not in "iuf":
                    continue
                columns[channel.name] = samples.astype(float)
                units[channel.name] = str(signal.unit or "")
                groups[channel.name] = index
    finally:
        mdf.close()
    return columns, units, groups


def provenance_comment(provenance: dict) -> str:
    """The header's XML comment: a text line and one ``<e name=…>`` per provenance key."""
    items = "".join(f"<e name={quoteattr(str(key))}>{escape(_text(value))}</e>"
                    for key, value in provenance.items())
    return (f"<HDcomment><TX>ripple-hil capture {escape(str(provenance.get('test_id', '')))}"
            f"</TX><common_properties>{items}</common_properties></HDcomment>")


def _text(value) -> str:
    return value if isinstance(value, str) else json.dumps(value, sort_keys=True, default=str)


def write_mdf4(capture: Capture, path: Path, provenance: dict) -> None:
    """Write ``capture`` as an MDF 4.10 file: master ``time_s`` [s], every other 1-D numeric
    channel with its unit, the capture's meta as the group's comment (JSON) and ``provenance``
    in the header."""
    from asammdf import MDF, Signal

    if "time_s" not in capture:
        raise InputError(f"{path.name}: the capture has no time_s channel (the MDF master)")
    time_s = np.asarray(capture["time_s"], dtype=float)
    signals = [Signal(samples=np.asarray(values), timestamps=time_s, name=name,
                      unit=capture.units.get(name, ""))
               for name, values in capture.channels.items()
               if name != "time_s" and np.asarray(values).ndim == 1
               and np.asarray(values).dtype.kind in "iuf"]
    mdf = MDF(version="4.10")
    try:
        mdf.header.author = "ripple-hil"
        mdf.header.project = str(provenance.get("record_id", ""))
        mdf.header.subject = str(provenance.get("test_id", ""))
        mdf.header.comment = provenance_comment(provenance)
        mdf.append(signals, comment=json.dumps(capture.meta, sort_keys=True, default=str))
        mdf.save(str(path), overwrite=True)
    finally:
        mdf.close()
