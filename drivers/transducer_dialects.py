"""Command dialects of the serial torque transducer: what to send, how to read the answers.

Two published styles are implemented from their public command lists (our own wording; where a
detail was not published or not certain, the choice is stated here):

**Magtrol** (DSP6001 / DSP7000 style). Commands and answers end with CR LF, upper case, one
command per line. ``*IDN?`` answers ``MAGTROL,<model>,<serial>,<firmware>``. ``OD`` answers
``S<speed>T<torque><d>``: speed in rpm without sign or leading zeros, torque with a decimal point
in the readout unit, ``d`` = ``R`` (clockwise, counted positive), ``L`` (counter-clockwise,
negative) or ``A`` (alarm; the driver raises DeviceFault). Our choice: the torque field may carry
a ``-`` sign (braking torque) and has 4 decimals. ``TS1`` / ``TR1`` enable / disable tare (zero at
the present reading). ``UR#`` sets the readout unit, # = 0 oz.in, 1 oz.ft, 2 lb.in, 3 lb.ft,
4 g.cm, 5 kg.cm, 6 N.mm, 7 N.cm, 8 N.m. Setting commands are silent (the instrument shows an
error on its panel, not on the line). The filter: the manuals list cutoffs of 3, 10, 25 and 50 Hz
but we could not confirm the command spelling, so ``TF#`` (0 off, 1..4 = 3/10/25/50 Hz) is our
assumption.

**Himmelstein** (MCRT 48200V style). Messages end with CR (LF accepted). ``MD`` model, ``SN``
serial number, ``VR`` version. ``DC`` torque in display units (native lbf-in times the display
scaling ``DS``, an IEEE-754 float sent as 8 hex digits). ``XC`` raw counts (4 hex digits, 16-bit
two's complement) and ``YC`` = ``<time>,<counts>`` with the time in 10 kHz ticks since power-on
(8 hex digits); ``SC`` = positive and negative scaling constants (lbf-in per count, 8 + 8 hex
digits). ``TT`` tares, ``FL`` reads / ``FL<nn>`` sets the filter code (2 = 200 Hz ... 12 =
0.1 Hz), ``UN`` reads / ``UN<name>`` sets the unit name. Setting messages answer ``OK``; errors
answer a ``!``-prefixed text (``!BadArg``, ``!<cmd>`` for an unknown command) -> DeviceFault.
Our choices: raw counts are net of the tare; the transducer has no speed channel (speed None).

Readings are returned in SI: the driver converts from the wire unit with the factors below.
"""

from __future__ import annotations

import re
import struct
from abc import ABC, abstractmethod
from dataclasses import dataclass

#: Newton-metres per unit of each torque unit the dialects name.
TORQUE_UNIT_NM = {
    "oz.in": 0.00706155181422604, "oz.ft": 0.0847386217707125, "lb.in": 0.112984829027617,
    "lb.ft": 1.35581794833140, "g.cm": 9.80665e-5, "kg.cm": 0.0980665, "N.mm": 1e-3,
    "N.cm": 1e-2, "N.m": 1.0,
}
LBF_IN_NM = TORQUE_UNIT_NM["lb.in"]

MAGTROL_UNIT_CODES = ("oz.in", "oz.ft", "lb.in", "lb.ft", "g.cm", "kg.cm", "N.mm", "N.cm", "N.m")
MAGTROL_FILTER_CUTOFF_HZ = {0: None, 1: 3.0, 2: 10.0, 3: 25.0, 4: 50.0}
HIMMELSTEIN_FILTER_CUTOFF_HZ = {2: 200.0, 3: 100.0, 4: 50.0, 5: 20.0, 6: 10.0, 7: 5.0, 8: 2.0,
                                9: 1.0, 10: 0.5, 11: 0.2, 12: 0.1}
HIMMELSTEIN_TICK_HZ = 10_000.0

MAGTROL_OD = re.compile(r"S(\d+)T(-?\d+\.\d*)([RLA])$")
HIMMELSTEIN_YC = re.compile(r"([0-9A-Fa-f]{8}),([0-9A-Fa-f]{4})$")
_HEX = re.compile(r"^[0-9A-Fa-f]+$")


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
    """IEEE-754 single as 8 upper-case hex digits (big-endian)."""
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

    def setup(self, io) -> None:
        """Read what the dialect needs to convert readings (called by connect)."""

    @abstractmethod
    def identity(self, io) -> dict:
        """Dialect-specific."""

    @abstractmethod
    def tare(self, io) -> None:
        """Dialect-specific."""

    @abstractmethod
    def set_units(self, io, unit: str) -> None:
        """Dialect-specific."""

    @abstractmethod
    def set_filter(self, io, code: int) -> None:
        """Dialect-specific."""

    @abstractmethod
    def parse_reading(self, line: str) -> Reading:
        """Dialect-specific."""


class MagtrolDialect(Dialect):
    """DSP6001 / DSP7000-style commands (see the module docstring)."""

    name = "magtrol"
    terminator = b"\r\n"
    read_command = "OD"
    filter_cutoff_hz = MAGTROL_FILTER_CUTOFF_HZ

    def __init__(self) -> None:
        self.unit = "N.m"

    def setup(self, io) -> None:
        io.send(f"UR{MAGTROL_UNIT_CODES.index(self.unit)}")

    def identity(self, io) -> dict:
        fields = [f.strip() for f in io.query("*IDN?").split(",")]
        if len(fields) < 4 or fields[0].upper() != "MAGTROL":
            raise DialectError(f"*IDN? answer {','.join(fields)!r} is not MAGTROL,model,serial,fw")
        return {"vendor": "Magtrol", "model": fields[1], "serial_number": fields[2],
                "firmware": ",".join(fields[3:])}

    def tare(self, io) -> None:
        io.send("TS1")

    def set_units(self, io, unit: str) -> None:
        io.send(f"UR{MAGTROL_UNIT_CODES.index(unit)}")
        self.unit = unit

    def set_filter(self, io, code: int) -> None:
        io.send(f"TF{code}")

    def parse_reading(self, line: str) -> Reading:
        match = MAGTROL_OD.search(line)
        if match is None:
            raise DialectError(f"OD answer {line!r} is not S<rpm>T<torque><R|L|A>")
        speed, torque, direction = match.groups()
        if direction == "A":
            raise DeviceReportedError(f"alarm condition reported in {match.group(0)!r}")
        sign = 1.0 if direction == "R" else -1.0
        return Reading(torque_nm=float(torque) * TORQUE_UNIT_NM[self.unit],
                       speed_rpm=sign * float(speed), time_s=None)


class HimmelsteinDialect(Dialect):
    """MCRT 48200V-style messages (see the module docstring)."""

    name = "himmelstein"
    terminator = b"\r"
    read_command = "YC"
    filter_cutoff_hz = HIMMELSTEIN_FILTER_CUTOFF_HZ

    def __init__(self) -> None:
        self.scale_pos_lbf_in = self.scale_neg_lbf_in = None
        self._last_ticks: int | None = None
        self._tick_wraps = 0

    @staticmethod
    def _ok(answer: str, command: str) -> None:
        if answer != "OK":
            raise DialectError(f"{command} answered {answer!r}, expected OK")

    def setup(self, io) -> None:
        answer = io.query("SC").replace(" ", "")
        if len(answer) != 16:
            raise DialectError(f"SC answer {answer!r} is not 16 hex digits")
        self.scale_pos_lbf_in = hex_to_float(answer[:8])
        self.scale_neg_lbf_in = hex_to_float(answer[8:])

    def identity(self, io) -> dict:
        return {"vendor": "Himmelstein", "model": io.query("MD"),
                "serial_number": io.query("SN"), "firmware": io.query("VR")}

    def tare(self, io) -> None:
        self._ok(io.query("TT"), "TT")

    def set_units(self, io, unit: str) -> None:
        self._ok(io.query(f"DS{float_to_hex(LBF_IN_NM / TORQUE_UNIT_NM[unit])}"), "DS")
        self._ok(io.query(f"UN{unit}"), "UN")

    def set_filter(self, io, code: int) -> None:
        self._ok(io.query(f"FL{code:02d}"), "FL")

    def counts_to_nm(self, counts: int) -> float:
        scale = self.scale_pos_lbf_in if counts >= 0 else self.scale_neg_lbf_in
        return counts * scale * LBF_IN_NM

    def parse_reading(self, line: str) -> Reading:
        match = HIMMELSTEIN_YC.search(line.replace(" ", ""))
        if match is None:
            raise DialectError(f"YC answer {line!r} is not <8 hex ticks>,<4 hex counts>")
        ticks = int(match.group(1), 16)
        if self._last_ticks is not None and ticks < self._last_ticks:
            self._tick_wraps += 1          # the 32-bit tick counter wrapped
        self._last_ticks = ticks
        time_s = (ticks + self._tick_wraps * 2**32) / HIMMELSTEIN_TICK_HZ
        torque_nm = self.counts_to_nm(hex_to_int16(match.group(2)))
        return Reading(torque_nm=torque_nm, speed_rpm=None, time_s=time_s)


DIALECTS = {"magtrol": MagtrolDialect, "himmelstein": HimmelsteinDialect}
