"""The DAQ register map (``drivers/data/daq_registers.toml``) and its word codecs.

The map is data, not code: the driver (``drivers.modbus_daq``) and the simulated DAQ
(``drivers.simulated.modbus_daq_server``) both load it, so they cannot drift apart. 32-bit values
and strings are sent high word first; a sample frame in the capture buffer holds the words of the
enabled channels in map order. Engineering value = raw * scale + offset, so ``scale`` is the DAQ's
LSB in SI units (the analysis needs it for its uncertainty budget).
"""

from __future__ import annotations

import struct
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hil.errors import InputError

DEFAULT_MAP_PATH = Path(__file__).parent / "data" / "daq_registers.toml"

_WORDS = {"uint16": 1, "int16": 1, "uint32": 2, "int32": 2, "float32": 2}
_STRUCT = {"uint16": ">H", "int16": ">h", "uint32": ">I", "int32": ">i", "float32": ">f"}


@dataclass(frozen=True)
class Register:
    """One named register (or register group) of the map."""

    name: str
    table: str            # "input" (function code 4) or "holding" (3, 6, 16)
    address: int          # 0-based protocol address
    type: str             # uint16 | int16 | uint32 | int32 | float32 | string
    words: int
    minimum: float | None = None
    maximum: float | None = None

    def encode(self, value) -> list[int]:
        """Value -> register words (high word first)."""
        if self.type == "string":
            data = str(value).encode("ascii")[: 2 * self.words].ljust(2 * self.words, b"\0")
            return list(struct.unpack(f">{self.words}H", data))
        if self.type == "uint16" and self.words > 1:
            return [int(v) & 0xFFFF for v in value]
        data = struct.pack(_STRUCT[self.type], value)
        return list(struct.unpack(f">{len(data) // 2}H", data))

    def decode(self, words: list[int]):
        """Register words -> value (str, int or float)."""
        if len(words) != self.words:
            raise ValueError(f"register {self.name}: expected {self.words} words, got {len(words)}")
        data = struct.pack(f">{len(words)}H", *words)
        if self.type == "string":
            return data.rstrip(b"\0").decode("ascii", errors="replace")
        if self.type == "uint16" and self.words > 1:
            return list(words)
        return struct.unpack(_STRUCT[self.type], data)[0]


@dataclass(frozen=True)
class Channel:
    """One capture channel: its mask bit, raw type and scaling (engineering = raw*scale+offset)."""

    name: str
    bit: int
    type: str             # int16 or uint32 (a counter)
    scale: float          # SI units per LSB
    offset: float

    @property
    def words(self) -> int:
        return _WORDS[self.type]

    @property
    def is_counter(self) -> bool:
        return self.type == "uint32"

    def to_raw(self, values: np.ndarray) -> tuple[np.ndarray, bool]:
        """Engineering values -> raw integers; returns (raw, clipped) with int16 saturation."""
        if self.is_counter:
            return np.asarray(values).astype(np.int64) & 0xFFFFFFFF, False
        raw = np.rint((np.asarray(values, dtype=float) - self.offset) / self.scale)
        clipped = bool(np.any(raw > 32767) or np.any(raw < -32768))
        return np.clip(raw, -32768, 32767).astype(np.int64), clipped

    def to_words(self, raw: np.ndarray) -> np.ndarray:
        """Raw integers -> (n, words) array of uint16 register words, high word first."""
        raw = np.asarray(raw, dtype=np.int64)
        if self.words == 1:
            return (raw & 0xFFFF).astype(np.uint16)[:, None]
        return np.stack([(raw >> 16) & 0xFFFF, raw & 0xFFFF], axis=1).astype(np.uint16)

    def from_words(self, words: np.ndarray) -> np.ndarray:
        """(n, words) uint16 array -> raw integers (int16 signed, or uint32 counter)."""
        words = np.asarray(words, dtype=np.uint16)
        if self.words == 1:
            return words[:, 0].view(np.int16).astype(np.int64)
        return (words[:, 0].astype(np.int64) << 16) | words[:, 1].astype(np.int64)


@dataclass(frozen=True)
class RegisterMap:
    """The parsed register map: device constants, registers by name, channels in buffer order."""

    device: dict
    control_codes: dict[str, int]
    states: dict[str, int]
    status_flags: dict[str, int]
    registers: dict[str, Register]
    channels: tuple[Channel, ...]
    source: str

    def __getitem__(self, name: str) -> Register:
        try:
            return self.registers[name]
        except KeyError:
            raise InputError(f"register map {self.source}: no register {name!r}; "
                             f"it has {sorted(self.registers)}") from None

    def channel(self, name: str) -> Channel:
        for channel in self.channels:
            if channel.name == name:
                return channel
        raise InputError(f"register map {self.source}: no channel {name!r}; "
                         f"it has {[c.name for c in self.channels]}")

    def mask_of(self, names) -> int:
        return sum(1 << self.channel(name).bit for name in names)

    def channels_in(self, mask: int) -> tuple[Channel, ...]:
        return tuple(c for c in self.channels if mask >> c.bit & 1)

    @property
    def all_channels_mask(self) -> int:
        return self.mask_of(c.name for c in self.channels)

    @property
    def window_words(self) -> int:
        return int(self.device["buffer_window_registers"])

    def state_name(self, code: int) -> str:
        for name, value in self.states.items():
            if value == code:
                return name
        return f"unknown({code})"


def load_register_map(path: str | Path | None = None) -> RegisterMap:
    """Read and check a register map file; a bad file raises InputError naming the key."""
    path = Path(path) if path is not None else DEFAULT_MAP_PATH
    try:
        data = tomllib.loads(path.read_text())
    except (OSError, tomllib.TOMLDecodeError) as exc:
        raise InputError(f"register map {str(path)!r} is not readable TOML: {exc}") from None
    try:
        registers = {}
        for name, entry in data["registers"].items():
            kind = entry["type"]
            if kind not in _WORDS and kind != "string":
                raise InputError(f"register map {path}: registers.{name}.type={kind!r}; "
                                 f"allowed {sorted(_WORDS) + ['string']}")
            if entry["table"] not in ("input", "holding"):
                raise InputError(f"register map {path}: registers.{name}.table="
                                 f"{entry['table']!r}; allowed 'input' or 'holding'")
            words = int(entry.get("words", _WORDS.get(kind, 1)))
            registers[name] = Register(name, entry["table"], int(entry["address"]), kind, words,
                                       entry.get("min"), entry.get("max"))
        channels = tuple(Channel(c["name"], int(c["bit"]), c["type"], float(c["scale"]),
                                 float(c.get("offset", 0.0))) for c in data["channels"])
        for channel in channels:
            if channel.type not in ("int16", "uint32"):
                raise InputError(f"register map {path}: channel {channel.name} type "
                                 f"{channel.type!r}; allowed 'int16' or 'uint32'")
        return RegisterMap(dict(data["device"]), dict(data["control_codes"]),
                           dict(data["states"]), dict(data["status_flags"]), registers,
                           channels, str(path))
    except KeyError as exc:
        raise InputError(f"register map {str(path)!r} lacks key {exc}") from None
