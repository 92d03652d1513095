"""The DAQ register map (``drivers/data/daq_registers.toml``) and its word codecs.

The map is data, not code: the driver (``ripple_hil_drivers.modbus_daq``) and the simulated DAQ
(``ripple_hil_drivers.simulated.modbus_daq_server``) both load it, so they cannot drift apart. 32-bit values
and strings are sent high word first; a sample frame in the capture buffer holds the words of the
enabled channels in map order. Engineering value = raw * scale + offset, so ``scale`` is the DAQ's
LSB in SI units (the analysis needs it for its uncertainty budget).

A channel is an ``int16`` scaled sample or a ``uint16``/``uint32`` free-running counter. A channel
may declare a ``packed_type``: in the DAQ's packed capture format it travels in that narrower type
(the encoder counter's low 16 bits, with the first sample's full value in a register), which the
driver reassembles exactly. Optional tables ``buffer_read_modes`` and ``capture_formats`` list the
values of the ``buffer_read_mode`` and ``capture_format`` registers; a map without them describes
a DAQ that offers only paged reads in the full format.

The capture sequence is data too (issue 31 item 2), so a DAQ that is not ours is described
without code: ``[roles]`` names, for each role the driver uses (``control``, ``state``,
``samples``, ``buffer_window``…, :data:`ROLES`), the DAQ's own register (loaded under the role's
name, its own name kept in ``Register.label``); ``[control_codes]`` and ``[states]`` hold its
codes; ``[transfer]`` says how the buffer travels: ``kind = "registers"`` (the default: the
``buffer_window`` read paged or with auto-increment) or ``kind = "file_record"`` (the standard
Read File Record function 0x14: word w of the buffer is record ``(first_record + w) mod
records_per_file`` of file
``first_file + (first_record + w) div records_per_file``, ``words_per_request`` per request,
one sub-request each). A map without ``[roles]`` and ``[transfer]`` is the shipped RHIL-DAQ16 map.
"""

from __future__ import annotations

import struct
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from hil.errors import InputError

DEFAULT_MAP_PATH = Path(__file__).parent / "data" / "daq_registers.toml"

_WORDS = {"uint16": 1, "int16": 1, "uint32": 2, "int32": 2, "float32": 2}
_CHANNEL_TYPES = ("int16", "uint16", "uint32")
_STRUCT = {"uint16": ">H", "int16": ">h", "uint32": ">I", "int32": ">i", "float32": ">f"}
#: The registers the driver and the simulated DAQ use by role (the capture sequence, the identity
#: and the dyno output); ``[roles]`` maps a role onto the DAQ's own register name.
ROLES = ("control", "state", "status_flags", "samples_captured", "words_per_sample",
         "sample_rate_hz", "samples", "channel_mask", "settle_ms", "capture_format",
         "buffer_page", "buffer_read_mode", "buffer_window", "model", "serial_number",
         "firmware", "map_version", "encoder_counts_per_rev", "pole_pairs",
         "buffer_capacity_samples", "max_sample_rate_hz", "dyno_speed_setpoint_rpm")
TRANSFER_KINDS = ("registers", "file_record")
#: Read File Record (0x14): records 0..9999 per file; a one-sub-request answer's data length
#: byte (<= 0xF5) holds 2 + 2·N bytes, so N <= 121 registers (spec v1.1b3 §6.14).
MAX_RECORDS_PER_FILE = 10000
MAX_FILE_RECORD_WORDS = 121


@dataclass(frozen=True)
class Transfer:
    """How the capture buffer travels: ``registers`` (the buffer window) or ``file_record``."""

    kind: str = "registers"
    first_file: int = 1
    records_per_file: int = MAX_RECORDS_PER_FILE
    words_per_request: int = 120
    first_record: int = 0

    def locate(self, word: int) -> tuple[int, int]:
        """(file number, record number) of buffer word ``word`` (file_record)."""
        linear = self.first_record + word
        return self.first_file + linear // self.records_per_file, linear % self.records_per_file

    def word_of(self, file: int, record: int) -> int:
        """The buffer word at (file, record); negative before the buffer's first record."""
        return (file - self.first_file) * self.records_per_file + record - self.first_record

    def requests(self, total: int) -> list[tuple[int, int, int]]:
        """(file, record, count) of each Read File Record request for ``total`` words: at most
        ``words_per_request`` each, none crossing a file's end."""
        out, word = [], 0
        while word < total:
            file, record = self.locate(word)
            count = min(self.words_per_request, total - word, self.records_per_file - record)
            out.append((file, record, count))
            word += count
        return out


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
    label: str = ""       # the DAQ's own name when [roles] renamed it ("" = same as name)

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
    """One capture channel: its mask bit, raw type and scaling (engineering = raw*scale+offset).

    ``wire_type`` / ``words`` describe the full capture format; ``packed`` selects the packed one.
    """

    name: str
    bit: int
    type: str             # int16 (scaled sample), uint16 or uint32 (a free-running counter)
    scale: float          # SI units per LSB
    offset: float
    packed_type: str | None = None             # narrower type in the packed format
    packed_first_register: str | None = None   # register with the first sample's full value

    def wire_type(self, packed: bool = False) -> str:
        return self.packed_type if packed and self.packed_type else self.type

    def words_in(self, packed: bool = False) -> int:
        return _WORDS[self.wire_type(packed)]

    @property
    def words(self) -> int:
        return _WORDS[self.type]

    @property
    def is_counter(self) -> bool:
        return self.type in ("uint16", "uint32")

    @property
    def counter_bits(self) -> int:
        return 16 * self.words

    @property
    def range_si(self) -> tuple[float, float] | None:
        """(lowest, highest) engineering value an ``int16`` sample can carry (either sign of
        ``scale``); None: a counter."""
        if self.is_counter:
            return None
        ends = (-32768 * self.scale + self.offset, 32767 * self.scale + self.offset)
        return (min(ends), max(ends))

    def to_raw(self, values: np.ndarray) -> tuple[np.ndarray, bool]:
        """Engineering values -> raw integers; returns (raw, clipped) with int16 saturation."""
        if self.is_counter:
            return np.asarray(values).astype(np.int64) & ((1 << self.counter_bits) - 1), False
        raw = np.rint((np.asarray(values, dtype=float) - self.offset) / self.scale)
        clipped = bool(np.any(raw > 32767) or np.any(raw < -32768))
        return np.clip(raw, -32768, 32767).astype(np.int64), clipped

    def to_words(self, raw: np.ndarray, packed: bool = False) -> np.ndarray:
        """Raw integers -> (n, words) array of uint16 register words, high word first (a packed
        counter keeps its low word)."""
        raw = np.asarray(raw, dtype=np.int64)
        if self.words_in(packed) == 1:
            return (raw & 0xFFFF).astype(np.uint16)[:, None]
        return np.stack([(raw >> 16) & 0xFFFF, raw & 0xFFFF], axis=1).astype(np.uint16)

    def from_words(self, words: np.ndarray, packed: bool = False) -> np.ndarray:
        """(n, words) uint16 array -> raw integers: int16 signed, a counter unsigned."""
        words = np.asarray(words, dtype=np.uint16)
        if self.words_in(packed) == 1:
            column = words[:, 0]
            return (column if self.is_counter else column.view(np.int16)).astype(np.int64)
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
    buffer_read_modes: dict[str, int] = field(default_factory=dict)
    capture_formats: dict[str, int] = field(default_factory=dict)
    transfer: Transfer = field(default_factory=Transfer)

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

    def frame_words(self, channels, packed: bool = False) -> int:
        """Words of one sample frame holding ``channels`` in the full or packed format."""
        return sum(channel.words_in(packed) for channel in channels)

    @property
    def sample_counter(self) -> Channel | None:
        """The time-base channel (``device.sample_counter_channel``), None if the DAQ has none."""
        name = self.device.get("sample_counter_channel")
        return self.channel(name) if name else None

    @property
    def offers_auto_increment(self) -> bool:
        return "auto_increment" in self.buffer_read_modes and "buffer_read_mode" in self.registers

    @property
    def offers_packed(self) -> bool:
        return "packed" in self.capture_formats and "capture_format" in self.registers

    @property
    def window_words(self) -> int:
        """Words one buffer request carries (the window, or a Read File Record request)."""
        if self.transfer.kind == "file_record":
            return self.transfer.words_per_request
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
        roles = _roles(data.get("roles", {}), data["registers"], path)
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
            address = int(entry["address"])
            if not 0 <= address <= address + words - 1 <= 0xFFFF or words < 1:
                raise InputError(f"register map {path}: registers.{name} spans addresses "
                                 f"{address}..{address + words - 1}; Modbus addresses are "
                                 f"0..65535 (16 bit)")
            role = roles.get(name, name)
            registers[role] = Register(role, entry["table"], address, kind, words,
                                       entry.get("min"), entry.get("max"),
                                       name if role != name else "")
        channels = tuple(Channel(c["name"], int(c["bit"]), c["type"], float(c["scale"]),
                                 float(c.get("offset", 0.0)), c.get("packed_type"),
                                 c.get("packed_first_register")) for c in data["channels"])
        for channel in channels:
            _check_channel(channel, registers, path)
        register_map = RegisterMap(dict(data["device"]), dict(data["control_codes"]),
                                   dict(data["states"]), dict(data["status_flags"]), registers,
                                   channels, str(path), dict(data.get("buffer_read_modes", {})),
                                   dict(data.get("capture_formats", {})),
                                   _transfer(data.get("transfer", {}), path))
        _check_transfer(register_map, path)
        register_map.sample_counter     # noqa: B018 - a named counter channel must exist
        return register_map
    except KeyError as exc:
        raise InputError(f"register map {str(path)!r} lacks key {exc}") from None


def _check_channel(channel: Channel, registers: dict[str, Register], path) -> None:
    """A channel's type, and its packed form (a counter's low word with a first-value register)."""
    if channel.type not in _CHANNEL_TYPES:
        raise InputError(f"register map {path}: channel {channel.name} type {channel.type!r}; "
                         f"allowed {', '.join(_CHANNEL_TYPES)}")
    if channel.packed_type is None:
        return
    if not (channel.is_counter and channel.packed_type == "uint16" and channel.words == 2):
        raise InputError(f"register map {path}: channel {channel.name} packed_type="
                         f"{channel.packed_type!r}; only a uint32 counter packs, as uint16")
    if channel.packed_first_register not in registers:
        raise InputError(f"register map {path}: channel {channel.name} packed_first_register="
                         f"{channel.packed_first_register!r} is not a register of the map")


def _roles(table: dict, registers: dict, path) -> dict[str, str]:
    """The DAQ's register name -> the role it plays (from ``[roles]``: role = "its name")."""
    out = {}
    for role, name in table.items():
        if role not in ROLES:
            raise InputError(f"register map {path}: roles.{role} is not a role the driver uses "
                             f"(allowed: {', '.join(ROLES)})")
        if name not in registers:
            raise InputError(f"register map {path}: roles.{role} = {name!r} is not a register "
                             "of the map")
        if role != name and role in registers:
            raise InputError(f"register map {path}: roles.{role} = {name!r}, but a register is "
                             f"already named {role!r}")
        out[name] = role
    return out


def _transfer(table: dict, path) -> Transfer:
    kind = table.get("kind", "registers")
    if kind not in TRANSFER_KINDS:
        raise InputError(f"register map {path}: transfer.kind = {kind!r}; allowed "
                         f"{', '.join(TRANSFER_KINDS)}")
    transfer = Transfer(kind, int(table.get("first_file", 1)),
                        int(table.get("records_per_file", MAX_RECORDS_PER_FILE)),
                        int(table.get("words_per_request", 120)),
                        int(table.get("first_record", 0)))
    if not 1 <= transfer.first_file <= 0xFFFF:
        raise InputError(f"register map {path}: transfer.first_file = {transfer.first_file}; "
                         "allowed 1..65535")
    if not 1 <= transfer.records_per_file <= MAX_RECORDS_PER_FILE:
        raise InputError(f"register map {path}: transfer.records_per_file = "
                         f"{transfer.records_per_file}; allowed 1..{MAX_RECORDS_PER_FILE}")
    if not 0 <= transfer.first_record < transfer.records_per_file:
        raise InputError(f"register map {path}: transfer.first_record = "
                         f"{transfer.first_record}; allowed 0..{transfer.records_per_file - 1}")
    if not 1 <= transfer.words_per_request <= MAX_FILE_RECORD_WORDS:
        raise InputError(f"register map {path}: transfer.words_per_request = "
                         f"{transfer.words_per_request}; allowed 1..{MAX_FILE_RECORD_WORDS}")
    return transfer


def _check_transfer(register_map: RegisterMap, path) -> None:
    """A register-window map needs its window; a file-record map offers no auto-increment."""
    if register_map.transfer.kind == "registers" and "buffer_window" not in register_map.registers:
        raise InputError(f"register map {path}: transfer.kind = \"registers\" needs a "
                         "buffer_window register (or roles.buffer_window naming it)")
    if register_map.transfer.kind == "file_record" and register_map.buffer_read_modes:
        raise InputError(f"register map {path}: buffer_read_modes belong to transfer.kind = "
                         "\"registers\"; a file_record map reads records")
