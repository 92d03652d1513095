"""Command dialects of the serial torque transducer: what to send, how to read the answers.

Both dialects follow the vendors' public manuals (our wording; the manuals' own example strings
are fed to these parsers in ``tests/drivers_transducer/test_manual_examples.py``). Sources:

* [DSP6000] Magtrol DSP6000 manual, ch. 5 "The DSP6000 with a PC": RS-232 at 300, 600, 1200,
  2400, 4800, 9600 or 19200 baud, no parity, 8 data bits, 1 stop bit; speed-torque data
  ``SdddddTdddd.R[cr][lf]`` ("no leading zeroes": the fixed-length speed field is padded with
  spaces), example ``S 1725T22.60R``.
* [DSP6001] Magtrol DSP6001 manual §8.6: commands in upper case, one per line, ended by CR LF;
  an unrecognised command only shows "I/O ERROR" on the panel (nothing on the line); ``*IDN?``
  "returns Magtrol identification and software revision" (layout not given); ``OD`` answers
  ``SxxxxxTxxxxxR``, ``...L`` or ``...A`` (A = alarm condition).
* [DSP7000] Magtrol DSP7000 manual §7.2.1 (``SddddddTdddd.R``, A = alarm), §7.4.2 (``OD1`` /
  ``OD2`` for channel 1 / 2), §7.4.7 (``TS1``/``TS2`` enable tare, ``TR1``/``TR2`` disable it).
* [6400] Magtrol Model 6400 manual §5.4: ``SdddddTdddd.RX`` where X is the direction-input digit
  (0 counter-clockwise, 1 clockwise; undefined when the direction input is off); example
  ``S 1725T22.60L1``.
* [6200] Magtrol Model 6200 manual §5.4: ``UR#`` sets the readout torque unit, # = 0 oz.in,
  1 oz.ft, 2 lb.in, 3 lb.ft, 4 g.cm, 5 kg.cm, 6 N.mm, 7 N.cm, 8 N.m.
* [3410] Magtrol 3410 manual §5.2: an unrecognised command answers ``COMMAND ERROR``.
* [MCRT] Himmelstein MCRT 48200V guide (rev. C), serial messages, and [NGRTM] Himmelstein reaction
  torquemeter guide, appendix IV: 38400 baud, 8N1; every message ends with CR (default) or LF;
  a setting is the query with the value appended and answers ``OK``; errors start with ``!``
  (``!BadArg``, ``!BadIndex``, ``!PasswordProtected``, ``!Unknown``, ``!xx`` unknown command).
  ``DC`` = torque in engineering units as a float (example ``1234.56``), the native lbf-in times
  the display scaling ``DS`` (an IEEE float as 8 hex digits, applied to ``DC`` only); ``SC`` =
  positive and negative scaling constants, lbf-in per count (chars 1-8 and 9-16, IEEE floats);
  ``YC`` = "time and current hexadecimal data" (``hex, hex``; time in 10 kHz ticks since power-on);
  ``TT`` tare (``OK``); ``FL`` filter code 2 = 200 Hz ... 12 = 0.1 Hz; ``UN`` unit name; ``MD``
  model, ``SN`` serial number, ``VR`` version (example ``Model MCRT48200V v1.2``).

Magtrol choices where the manuals are silent: the torque field is read with an optional ``-``
(the manuals show no sign; a transducer display may show one for reverse torque); the speed is
signed by the direction letter (R positive); the 6400's direction digit is accepted and ignored
(the letter is the documented direction; the manual's own example, given for a clockwise motor,
prints ``L1``, contradicting its table, so the digit is not trusted). ``*IDN?`` is parsed
tolerantly: comma-separated fields ``vendor,model,serial,firmware`` (IEEE 488.2 style) when
there are commas, else whitespace-separated ``vendor model firmware...``; any non-empty answer is
accepted and kept whole as ``idn``. No filter command is published for these instruments, so
``set_filter`` is refused (set the filter on the panel). Tare is published for the DSP7000
channels only; ``UR#`` for the single-channel units only.

Himmelstein choices: readings by ``DC`` (documented), converted with the ``DS`` read at connect.
The ``YC`` layout is NOT given by the public manuals: the optional ``timestamped=True`` mode
assumes ``<time>,<counts>`` with the time as up to 8 hex digits (32-bit tick counter, unwrapped
here) and the counts as 4 hex digits (16-bit two's complement, as the 16-bit tare value ``TV``
suggests), scaled by ``SC``. The manual's worked example "set the filter to 100 Hz: send FL02"
contradicts its own table (2 = 200 Hz, 3 = 100 Hz); the table is followed.

Readings are returned in SI: the driver converts from the wire unit with the factors below.
"""

from __future__ import annotations

import re
import struct
from abc import ABC, abstractmethod
from dataclasses import dataclass

from hil.errors import InputError

#: Newton-metres per unit of each torque unit the dialects name.
TORQUE_UNIT_NM = {
    "oz.in": 0.00706155181422604, "oz.ft": 0.0847386217707125, "lb.in": 0.112984829027617,
    "lb.ft": 1.35581794833140, "g.cm": 9.80665e-5, "kg.cm": 0.0980665, "N.mm": 1e-3,
    "N.cm": 1e-2, "N.m": 1.0,
}
LBF_IN_NM = TORQUE_UNIT_NM["lb.in"]

MAGTROL_UNIT_CODES = ("oz.in", "oz.ft", "lb.in", "lb.ft", "g.cm", "kg.cm", "N.mm", "N.cm", "N.m")
HIMMELSTEIN_FILTER_CUTOFF_HZ = {2: 200.0, 3: 100.0, 4: 50.0, 5: 20.0, 6: 10.0, 7: 5.0, 8: 2.0,
                                9: 1.0, 10: 0.5, 11: 0.2, 12: 0.1}
HIMMELSTEIN_TICK_HZ = 10_000.0

MAGTROL_OD = re.compile(r"S *(\d+)T *(-?) *(\d+\.\d*|\.\d+)([RLA])([01]?)$")
MAGTROL_COMMAND_ERROR = "COMMAND ERROR"
HIMMELSTEIN_YC = re.compile(r"([0-9A-Fa-f]{1,8}), *([0-9A-Fa-f]{4})$")
_FLOAT = re.compile(r"^[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$")
_HEX = re.compile(r"^[0-9A-Fa-f]+$")


@dataclass(frozen=True)
class LineSettings:
    """A family's published serial line: the allowed rates (first = default) and the framing."""

    baudrates: tuple[int, ...]
    bytesize: int = 8
    parity: str = "N"
    stopbits: int = 1

    @property
    def default_baudrate(self) -> int:
        return self.baudrates[0]


#: [DSP6000] 300..19200 baud 8N1 (default: the fastest); [NGRTM] 38400 baud 8N1.
LINE_SETTINGS = {
    "magtrol": LineSettings(baudrates=(19200, 9600, 4800, 2400, 1200, 600, 300)),
    "himmelstein": LineSettings(baudrates=(38400,)),
}


@dataclass(frozen=True)
class Reading:
    """One transducer reading in SI units; ``time_s`` is the device time stamp if it has one."""

    torque_nm: float
    speed_rpm: float | None
    time_s: float | None = None


class DialectError(ValueError):
    """An answer that does not fit the dialect (the driver turns it into ProtocolError)."""


class DeviceReportedError(Exception):
    """The instrument answered an error message (the driver turns it into DeviceFault)."""


def float_to_hex(value: float) -> str:
    """IEEE-754 single as 8 upper-case hex digits (big-endian, [NGRTM] "MSB first")."""
    return struct.pack(">f", value).hex().upper()


def hex_to_float(text: str) -> float:
    if len(text) != 8 or not _HEX.match(text):
        raise DialectError(f"expected 8 hex digits of an IEEE float, got {text!r}")
    return struct.unpack(">f", bytes.fromhex(text))[0]


def hex_to_int16(text: str) -> int:
    if len(text) != 4 or not _HEX.match(text):
        raise DialectError(f"expected 4 hex digits, got {text!r}")
    value = int(text, 16)
    return value - 0x10000 if value >= 0x8000 else value


class Dialect(ABC):
    """Base of a dialect: the driver calls these with an ``io`` offering send/query."""

    name = ""
    terminator = b"\r\n"
    read_command = ""
    filter_cutoff_hz: dict[int, float | None] = {}

    @property
    def line(self) -> LineSettings:
        return LINE_SETTINGS[self.name]

    def setup(self, io) -> None:
        """Read or set what the dialect needs to convert readings (called by connect)."""

    @abstractmethod
    def identity(self, io) -> dict:
        """Vendor, model, serial number, firmware as the instrument reports them."""

    @abstractmethod
    def tare(self, io) -> None:
        """Zero the reading at the present torque."""

    @abstractmethod
    def set_units(self, io, unit: str) -> None:
        """Make the instrument send torque in ``unit`` (a ``TORQUE_UNIT_NM`` key)."""

    def set_filter(self, io, code: int) -> None:
        raise InputError(f"torque: the {self.name} manuals publish no filter command; set the "
                         f"filter on the instrument")

    @abstractmethod
    def parse_reading(self, line: str) -> Reading:
        """One data answer as a Reading in SI units."""


class MagtrolDialect(Dialect):
    """Magtrol DSP6001 / 6400 (``OD``, ``channel=None``) or DSP7000 (``OD1``/``OD2``)."""

    name = "magtrol"
    terminator = b"\r\n"

    def __init__(self, channel: int | None = None, unit: str = "N.m") -> None:
        if channel not in (None, 1, 2):
            raise InputError(f"torque magtrol channel={channel!r}; allowed None (single-channel "
                             f"DSP6001/6400: OD), 1 or 2 (DSP7000: OD1/OD2)")
        if unit not in TORQUE_UNIT_NM:
            raise InputError(f"torque unit={unit!r}; allowed {sorted(TORQUE_UNIT_NM)}")
        self.channel = channel
        self.unit = unit          # the unit the instrument displays (and so sends)
        self.read_command = "OD" if channel is None else f"OD{channel}"

    def setup(self, io) -> None:
        """Single-channel units: ``UR#`` makes the readout unit ours; DSP7000: stated by the user."""
        if self.channel is None:
            io.send(f"UR{MAGTROL_UNIT_CODES.index(self.unit)}")

    def identity(self, io) -> dict:
        raw = io.query("*IDN?")
        if raw.upper().startswith(MAGTROL_COMMAND_ERROR):
            raise DeviceReportedError(f"*IDN? answered {raw!r}")
        if "," in raw:
            fields = [f.strip() for f in raw.split(",")]
            vendor, model, serial, firmware = (fields + ["", "", ""])[:3] + [",".join(fields[3:])]
        else:
            fields = raw.split()
            vendor, serial, firmware = fields[0], "", " ".join(fields[2:])
            model = fields[1] if len(fields) > 1 else ""
        return {"vendor": "Magtrol", "model": model, "serial_number": serial,
                "firmware": firmware, "idn": raw, "idn_vendor": vendor}

    def tare(self, io) -> None:
        if self.channel is None:
            raise InputError("torque: the single-channel Magtrol manuals (DSP6001, 6400) publish "
                             "no tare command; tare on the panel, or use a DSP7000 channel")
        io.send(f"TS{self.channel}")

    def set_units(self, io, unit: str) -> None:
        if self.channel is not None:
            raise InputError("torque: the DSP7000 manual publishes no readout-unit command; set "
                             "the unit on the panel and state it (unit=...)")
        io.send(f"UR{MAGTROL_UNIT_CODES.index(unit)}")
        self.unit = unit

    def parse_reading(self, line: str) -> Reading:
        if line.strip().upper() == MAGTROL_COMMAND_ERROR:
            raise DeviceReportedError(f"{self.read_command} answered {line!r}")
        match = MAGTROL_OD.search(line)
        if match is None:
            raise DialectError(f"{self.read_command} answer {line!r} is not "
                               f"S<rpm>T<torque><R|L|A>[0|1]")
        speed, sign, torque, direction, _digit = match.groups()
        if direction == "A":
            raise DeviceReportedError(f"alarm condition reported in {match.group(0)!r}")
        torque_value = float(torque) * (-1.0 if sign else 1.0)
        return Reading(torque_nm=torque_value * TORQUE_UNIT_NM[self.unit],
                       speed_rpm=(1.0 if direction == "R" else -1.0) * float(speed), time_s=None)


class HimmelsteinDialect(Dialect):
    """MCRT 48200V messages: ``DC`` readings, or ``YC`` with ``timestamped=True`` (assumed layout)."""

    name = "himmelstein"
    terminator = b"\r"
    filter_cutoff_hz = HIMMELSTEIN_FILTER_CUTOFF_HZ

    def __init__(self, timestamped: bool = False) -> None:
        self.timestamped = bool(timestamped)
        self.read_command = "YC" if self.timestamped else "DC"
        self.display_scaling: float | None = None       # display units per lbf-in (DS)
        self.scale_pos_lbf_in = self.scale_neg_lbf_in = None
        self._last_ticks: int | None = None
        self._tick_wraps = 0

    @staticmethod
    def _ok(answer: str, command: str) -> None:
        if answer != "OK":
            raise DialectError(f"{command} answered {answer!r}, expected OK")

    def setup(self, io) -> None:
        self.display_scaling = self._display_scaling(io.query("DS"))
        if self.timestamped:
            answer = io.query("SC").replace(" ", "")
            if len(answer) != 16:
                raise DialectError(f"SC answer {answer!r} is not 16 hex digits")
            self.scale_pos_lbf_in = hex_to_float(answer[:8])
            self.scale_neg_lbf_in = hex_to_float(answer[8:])

    @staticmethod
    def _display_scaling(answer: str) -> float:
        value = hex_to_float(answer.strip())
        if not value > 0 or value != value or value == float("inf"):
            raise DialectError(f"DS answer {answer!r} is not a positive display scaling")
        return value

    def identity(self, io) -> dict:
        return {"vendor": "Himmelstein", "model": io.query("MD"),
                "serial_number": io.query("SN"), "firmware": io.query("VR")}

    def tare(self, io) -> None:
        self._ok(io.query("TT"), "TT")

    def set_units(self, io, unit: str) -> None:
        scaling = LBF_IN_NM / TORQUE_UNIT_NM[unit]
        self._ok(io.query(f"DS{float_to_hex(scaling)}"), "DS")
        self.display_scaling = self._display_scaling(float_to_hex(scaling))
        self._ok(io.query(f"UN{unit}"), "UN")

    def set_filter(self, io, code: int) -> None:
        self._ok(io.query(f"FL{code:02d}"), "FL")

    def counts_to_nm(self, counts: int) -> float:
        scale = self.scale_pos_lbf_in if counts >= 0 else self.scale_neg_lbf_in
        return counts * scale * LBF_IN_NM

    def parse_reading(self, line: str) -> Reading:
        return self._parse_yc(line) if self.timestamped else self._parse_dc(line)

    def _parse_dc(self, line: str) -> Reading:
        text = line.strip()
        if not _FLOAT.match(text):
            raise DialectError(f"DC answer {line!r} is not a number")
        if self.display_scaling is None:
            raise DialectError("DC answer before the display scaling DS was read (not connected)")
        return Reading(torque_nm=float(text) / self.display_scaling * LBF_IN_NM, speed_rpm=None)

    def _parse_yc(self, line: str) -> Reading:
        match = HIMMELSTEIN_YC.fullmatch(line.strip())
        if match is None:
            raise DialectError(f"YC answer {line!r} is not <hex ticks>,<4 hex counts> "
                               f"(the assumed layout)")
        ticks = int(match.group(1), 16)
        if self._last_ticks is not None and ticks < self._last_ticks:
            self._tick_wraps += 1          # the 32-bit tick counter wrapped
        self._last_ticks = ticks
        time_s = (ticks + self._tick_wraps * 2**32) / HIMMELSTEIN_TICK_HZ
        torque_nm = self.counts_to_nm(hex_to_int16(match.group(2)))
        return Reading(torque_nm=torque_nm, speed_rpm=None, time_s=time_s)


DIALECTS = {"magtrol": MagtrolDialect, "himmelstein": HimmelsteinDialect}


def make_dialect(name: str, options: dict | None = None) -> Dialect:
    """The dialect ``name`` built with ``options`` (InputError naming a bad name or option)."""
    if name not in DIALECTS:
        raise InputError(f"torque dialect={name!r}; allowed {sorted(DIALECTS)}")
    try:
        return DIALECTS[name](**(options or {}))
    except TypeError as exc:
        raise InputError(f"torque {name} options {options!r}: {exc}") from None
