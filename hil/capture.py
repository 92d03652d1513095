"""A captured (or simulated) set of synchronous signals, and its ``.npz`` file format.

Channel names carry their SI unit as a suffix (``torque_nm``, ``time_s``, ``ia_a``,
``rotor_angle_mech_rad``, ``dc_bus_v``, ``encoder_counts``); ``units`` repeats it explicitly so a
file is self-describing. ``meta`` holds scalars and strings (pole pairs, counts per revolution,
sample rate, instrument names) and is stored as JSON inside the file. Files are written
atomically and a SHA-256 of the bytes on disk is returned, for the run record.
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import tempfile
import zipfile
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from hil.errors import InputError

REQUIRED_CHANNELS = ("time_s",)
#: zlib level of the capture files (1: fast; numpy's savez_compressed uses the default, 6).
COMPRESS_LEVEL = 1
#: Member time stamp in the zip (fixed: the same capture gives the same bytes and SHA-256).
_ZIP_TIME = (1980, 1, 1, 0, 0, 0)


@dataclass
class Capture:
    """Synchronous sampled channels with units and metadata."""

    channels: dict[str, np.ndarray]
    units: dict[str, str] = field(default_factory=dict)
    meta: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        lengths = {name: len(values) for name, values in self.channels.items()}
        if len(set(lengths.values())) > 1:
            raise InputError(f"capture channels differ in length: {lengths}")
        for name in self.channels:
            self.units.setdefault(name, _unit_from_name(name))

    def __getitem__(self, name: str) -> np.ndarray:
        try:
            return self.channels[name]
        except KeyError:
            raise InputError(
                f"capture has no channel {name!r}; it has {sorted(self.channels)}") from None

    def __contains__(self, name: str) -> bool:
        return name in self.channels

    def __len__(self) -> int:
        return len(next(iter(self.channels.values()))) if self.channels else 0

    def to_bytes(self) -> bytes:
        """The ``.npz`` bytes: one ``.npy`` member per channel plus the JSON header, deflated at
        level 1 (issue 17 item 3: ADC-quantised channels shrink ~3x at level 1 in a fifth of the
        time numpy's default level 6 takes, for 10 % more bytes)."""
        buffer = io.BytesIO()
        header = json.dumps({"units": self.units, "meta": self.meta}, sort_keys=True, default=str)
        members = {"__header__": np.frombuffer(header.encode(), dtype=np.uint8)}
        members |= {f"ch_{name}": np.asarray(values) for name, values in self.channels.items()}
        with zipfile.ZipFile(buffer, "w", compression=zipfile.ZIP_DEFLATED,
                             compresslevel=COMPRESS_LEVEL) as archive:
            for name, array in members.items():
                member = io.BytesIO()
                np.lib.format.write_array(member, array, allow_pickle=False)
                archive.writestr(zipfile.ZipInfo(f"{name}.npy", date_time=_ZIP_TIME),
                                 member.getvalue(), compress_type=zipfile.ZIP_DEFLATED,
                                 compresslevel=COMPRESS_LEVEL)
        return buffer.getvalue()

    def save(self, path: str | os.PathLike) -> str:
        """Write atomically (temp file + rename) and return the SHA-256 of the file's bytes."""
        data = self.to_bytes()
        atomic_write_bytes(Path(path), data)
        return hashlib.sha256(data).hexdigest()

    @classmethod
    def load(cls, path: str | os.PathLike) -> "Capture":
        """Read a capture file; a missing, truncated or foreign file raises InputError."""
        path = Path(path)
        if path.is_dir():
            raise InputError(f"capture file {str(path)!r} is a directory, not a capture")
        if not path.is_file():
            raise InputError(f"capture file {str(path)!r} does not exist")
        if not zipfile.is_zipfile(path):   # numpy would try it as a pickle and say allow_pickle
            raise InputError(f"capture file {str(path)!r} is not a ripple-hil capture (.npz, a "
                             "zip archive); another DAQ's CSV or npz: hil analyze --time-col …")
        try:
            with np.load(path, allow_pickle=False) as npz:
                header = json.loads(bytes(npz["__header__"]).decode())
                channels = {key[3:]: npz[key] for key in npz.files if key.startswith("ch_")}
        except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile, zlib.error,
                NotImplementedError, UnicodeDecodeError) as exc:   # JSONDecodeError is a ValueError
            raise InputError(f"capture file {str(path)!r} is not a readable ripple-hil capture "
                             f"({type(exc).__name__}: {exc})") from None
        if not isinstance(header, dict) or not all(
                isinstance(header.get(key, {}), dict) for key in ("units", "meta")):
            raise InputError(f"capture file {str(path)!r} has a damaged header (not a JSON object "
                             "with 'units' and 'meta' objects)")
        flat = [name for name, values in channels.items() if values.ndim != 1]
        if flat:
            raise InputError(f"capture file {str(path)!r}: channel(s) {flat} are not 1-D arrays")
        missing = [name for name in REQUIRED_CHANNELS if name not in channels]
        if missing:
            raise InputError(f"capture file {str(path)!r} lacks channel(s) {missing}")
        return cls(channels=channels, units=header.get("units", {}), meta=header.get("meta", {}))


    @staticmethod
    def read_meta(path: str | os.PathLike) -> dict:
        """The ``meta`` of a capture file, reading its header member only (not the channels)."""
        try:
            with np.load(Path(path), allow_pickle=False) as npz:
                header = json.loads(bytes(npz["__header__"]).decode())
        except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile, zlib.error,
                UnicodeDecodeError) as exc:
            raise InputError(f"capture file {str(path)!r} is not a readable ripple-hil capture "
                             f"({type(exc).__name__}: {exc})") from None
        meta = header.get("meta") if isinstance(header, dict) else None
        return meta if isinstance(meta, dict) else {}


def atomic_write_bytes(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` via a temp file in the same folder, fsync and rename."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as handle:
            handle.write(data)
            handle.flush()
            os.fsync(handle.fileno())
        os.chmod(tmp, 0o644)      # mkstemp creates 0600; records are meant to be read by others
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


_SUFFIX_UNITS = {"_s": "s", "_nm": "N*m", "_a": "A", "_v": "V", "_rad": "rad", "_rpm": "rpm",
                 "_hz": "Hz", "_counts": "counts", "_pu": "1"}


def _unit_from_name(name: str) -> str:
    for suffix, unit in _SUFFIX_UNITS.items():
        if name.endswith(suffix):
            return unit
    return ""
