"""NI TDMS measurement files (read with npTDMS): columns, their units and a time column.

Each channel is a column named by its channel name (a name in a second group: ``GROUP/NAME``)
with the unit of its ``unit_string`` property (LabVIEW's convention). A group of waveform channels
(``wf_increment`` set, equal for all of them, equal lengths) without a channel named like a time
column gets a ``time`` column [s] from their time track (``wf_start_offset + i·wf_increment``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from hil.errors import InputError

#: First 4 bytes of a TDMS file's lead-in.
MAGIC = b"TDSm"
#: The column added for a group of waveform channels without a time channel of their own.
TIME_COLUMN = "time"


def is_tdms(path: Path) -> bool:
    """True for a file that starts with a TDMS lead-in."""
    try:
        with open(path, "rb") as handle:
            return handle.read(4) == MAGIC
    except OSError:
        return False


def read_tdms(path: Path) -> tuple[dict[str, np.ndarray], dict[str, str], dict[str, int]]:
    """(columns, units, group index of each column) of a TDMS file."""
    from nptdms import TdmsFile

    try:
        tdms = TdmsFile.read(str(path))
    except Exception as exc:  # noqa: BLE001 - npTDMS raises many kinds on a damaged file
        raise InputError(f"{str(path)!r} is not a readable TDMS file "
                         f"({type(exc).__name__}: {exc})") from None
    columns: dict[str, np.ndarray] = {}
    units: dict[str, str] = {}
    groups: dict[str, int] = {}
    for index, group in enumerate(tdms.groups()):
        waveforms = []
        for channel in group.channels():
            data = np.asarray(channel[:])
            if data.ndim != 1 or data.dtype.kind not in "iuf":
                continue
            name = channel.name if channel.name not in columns else \
                f"{group.name}/{channel.name}"
            columns[name] = data.astype(float)
            units[name] = str(channel.properties.get("unit_string", ""))
            groups[name] = index
            if "wf_increment" in channel.properties:
                waveforms.append((channel, data.size))
        time = _time_track(waveforms)
        if time is not None and TIME_COLUMN not in columns:
            columns[TIME_COLUMN], units[TIME_COLUMN], groups[TIME_COLUMN] = time, "s", index
    return columns, units, groups


def _time_track(waveforms) -> np.ndarray | None:
    """The common time track of a group's waveform channels, None if they do not share one."""
    if not waveforms:
        return None
    first, size = waveforms[0]
    keys = {(float(c.properties["wf_increment"]),
             float(c.properties.get("wf_start_offset", 0.0)), n) for c, n in waveforms}
    if len(keys) != 1 or not size:
        return None
    ((increment_s, offset_s, _),) = keys
    # t = wf_start_offset + n·wf_increment (NI's waveform attributes; an absent offset is 0 —
    # npTDMS's own time_track() raises KeyError then, a review found it crashing hil analyze)
    return offset_s + increment_s * np.arange(size, dtype=float)
