"""Driver of the serial torque transducer (pyserial), in the Magtrol or the Himmelstein dialect.

The transport is line based: the driver accumulates bytes until the dialect's terminator (CR or
LF; empty lines from CR LF pairs are skipped), so partial lines across reads are joined;
non-printable bytes are dropped, so line noise before an answer does not break a parse. Before
each question the input buffer is flushed (stale or garbage bytes from earlier). An answer that
does not parse is asked again ``retries`` times, then raises ProtocolError; silence raises
InstrumentTimeout; an error message from the instrument (Himmelstein ``!...``, Magtrol alarm
``A`` or ``COMMAND ERROR``) raises DeviceFault; a port that cannot be opened or that vanishes (a
serial or OS error: unplugged adapter, closed pseudo-terminal) raises TransportLost with the
operating system's reason, from the original error. Readings are returned in SI (``Reading.torque_nm``) whatever unit the
instrument is set to.

Line settings follow the dialect's published family defaults (``transducer_dialects.LINE_SETTINGS``:
Magtrol 300..19200 baud, default 19200; Himmelstein 38400; both 8N1) unless stated; a rate the
family does not publish is refused. ``dialect_options`` go to the dialect (Magtrol ``channel``
1/2 for a DSP7000 and the ``unit`` it displays; Himmelstein ``timestamped``).

``stream(n)``: neither dialect has a free-running output in the command sets we follow, so a
stream is ``n`` back-to-back readings requested in pipelined chunks (``STREAM_CHUNK`` requests
written at once, then their answers read), which is as fast as the line allows. Himmelstein
readings by ``DC`` have neither speed nor time stamp (``timestamped=True`` reads ``YC``, an
assumed layout, with the 10 kHz device time stamp); Magtrol readings have ``time_s=None`` and a
signed speed.
"""

from __future__ import annotations

import termios
import time
from dataclasses import dataclass

import serial

from ripple_hil_drivers.errors import (DeviceFault, InstrumentError, InstrumentTimeout, ProtocolError,
                            TransportLost, transport_reason)
from ripple_hil_drivers.transducer_dialects import (TORQUE_UNIT_NM, DeviceReportedError, DialectError,
                                         Reading, make_dialect)
from hil.errors import InputError

__all__ = ["Reading", "SerialSettings", "TorqueTransducer"]

STREAM_CHUNK = 32
_NON_PRINTABLE = bytes(b for b in range(256) if not 0x20 <= b < 0x7F)
#: What pyserial and the OS raise when a port is gone (pyserial's SerialException is an OSError;
#: a raw OSError comes from ``in_waiting``'s ioctl, termios.error from a flush or a setting).
_PORT_ERRORS = (OSError, termios.error)


@dataclass(frozen=True)
class SerialSettings:
    """Serial line of the transducer; None = the dialect's published default."""

    port: str
    baudrate: int | None = None
    bytesize: int | None = None
    parity: str | None = None
    stopbits: int | None = None


class TorqueTransducer:
    """A torque transducer on a serial line; context manager or ``connect()`` / ``close()``."""

    def __init__(self, settings: SerialSettings, dialect: str = "magtrol",
                 timeout_s: float = 0.5, instrument_name: str = "torque",
                 retries: int = 1, dialect_options: dict | None = None) -> None:
        self.dialect = make_dialect(dialect, dialect_options)
        if not timeout_s > 0:
            raise InputError(f"torque timeout_s={timeout_s} must be > 0")
        if not 0 <= retries <= 10:
            raise InputError(f"torque retries={retries} outside 0..10")
        self.settings = self._line_settings(settings)
        self.timeout_s = timeout_s
        self.name = instrument_name
        self.retries = retries
        self._serial: serial.Serial | None = None
        self._pending = bytearray()
        self._action = ""

    def _line_settings(self, settings: SerialSettings) -> SerialSettings:
        """``settings`` with the dialect's published defaults filled in; unpublished rates refused."""
        line = self.dialect.line
        baudrate = settings.baudrate if settings.baudrate is not None else line.default_baudrate
        if baudrate not in line.baudrates:
            raise InputError(f"torque baudrate={baudrate!r} is not published for the "
                             f"{self.dialect.name} dialect; allowed {sorted(line.baudrates)}")
        return SerialSettings(
            settings.port, baudrate,
            settings.bytesize if settings.bytesize is not None else line.bytesize,
            settings.parity if settings.parity is not None else line.parity,
            settings.stopbits if settings.stopbits is not None else line.stopbits)

    # ------------------------------------------------------------------ connection
    def connect(self) -> "TorqueTransducer":
        s = self.settings
        try:
            self._serial = serial.Serial(s.port, baudrate=s.baudrate, bytesize=s.bytesize,
                                         parity=s.parity, stopbits=s.stopbits, timeout=0.05)
        except ValueError as exc:
            raise InstrumentError(self.name, "connect", f"cannot open {s.port}: {exc}") from exc
        except _PORT_ERRORS as exc:
            raise TransportLost(self.name, "connect", transport_reason(exc),
                                what=f"cannot open {s.port}") from exc
        self._transaction("set up", lambda: self.dialect.setup(self))
        return self

    def close(self) -> None:
        port, self._serial = self._serial, None
        if port is not None:
            try:
                port.close()
            except _PORT_ERRORS:
                pass                    # a port that vanished has nothing left to release

    def __enter__(self) -> "TorqueTransducer":
        return self.connect()

    def __exit__(self, *exc) -> None:
        self.close()

    # ------------------------------------------------------------------ public API
    def identity(self) -> dict:
        """Vendor, model, serial number, firmware as the instrument reports them."""
        return self._transaction("identity", lambda: self.dialect.identity(self))

    def tare(self) -> None:
        """Zero the torque reading at the present torque."""
        self._transaction("tare", lambda: self.dialect.tare(self))

    def set_units(self, unit: str) -> None:
        """Set the instrument's torque unit (readings stay in N·m)."""
        if unit not in TORQUE_UNIT_NM:
            raise InputError(f"torque unit={unit!r}; allowed {sorted(TORQUE_UNIT_NM)}")
        self._transaction(f"set units {unit}", lambda: self.dialect.set_units(self, unit))

    def set_filter(self, code: int) -> None:
        """Set the instrument's filter code (dialect's table: ``dialect.filter_cutoff_hz``)."""
        if self.dialect.filter_cutoff_hz and code not in self.dialect.filter_cutoff_hz:
            raise InputError(f"torque filter code={code!r} for {self.dialect.name}; allowed "
                             f"{sorted(self.dialect.filter_cutoff_hz)} (cutoffs Hz "
                             f"{self.dialect.filter_cutoff_hz})")
        self._transaction(f"set filter {code}", lambda: self.dialect.set_filter(self, code))

    def read(self) -> Reading:
        """One polled reading."""
        return self._transaction("read", lambda: self.dialect.parse_reading(
            self.query(self.dialect.read_command)))

    def stream(self, n: int) -> list[Reading]:
        """``n`` back-to-back readings, requested in pipelined chunks (see module docstring)."""
        if n < 1:
            raise InputError(f"torque stream n={n} must be >= 1")
        readings: list[Reading] = []
        bad_allowed = self.retries + n // 10
        self._action = f"stream {n} readings"
        self._require_open()
        self._flush_input()
        while len(readings) < n:
            k = min(STREAM_CHUNK, n - len(readings))
            request = self.dialect.read_command.encode("ascii") + self.dialect.terminator
            self._write(request * k)
            deadline = time.monotonic() + self.timeout_s + k * self._line_time_s()
            for _ in range(k):
                line = self._read_line(deadline)
                if line.startswith("!"):
                    raise DeviceFault(self.name, self._action, f"{line!r} in the stream")
                try:
                    readings.append(self.dialect.parse_reading(line))
                except DeviceReportedError as exc:
                    raise DeviceFault(self.name, self._action, str(exc)) from None
                except DialectError as exc:
                    bad_allowed -= 1
                    if bad_allowed < 0:
                        raise ProtocolError(self.name, self._action, str(exc)) from None
        return readings[:n]

    # ------------------------------------------------------------------ io used by dialects
    def send(self, command: str) -> None:
        """Write one command line (no answer expected)."""
        self._require_open()
        self._write(command.encode("ascii") + self.dialect.terminator)

    def query(self, command: str) -> str:
        """Write one command line and return its answer line; ``!...`` answers raise."""
        self._require_open()
        self._flush_input()
        self._write(command.encode("ascii") + self.dialect.terminator)
        line = self._read_line(time.monotonic() + self.timeout_s)
        if line.startswith("!"):
            raise DeviceReportedError(f"{command!r} answered {line!r}")
        return line

    # ------------------------------------------------------------------ transport
    def _transaction(self, action: str, body):
        self._action = action
        for attempt in range(self.retries + 1):
            try:
                return body()
            except DialectError as exc:
                if attempt == self.retries:
                    raise ProtocolError(self.name, action, str(exc)) from None
            except DeviceReportedError as exc:
                raise DeviceFault(self.name, action, str(exc)) from None
        raise AssertionError("unreachable")

    def _require_open(self) -> None:
        if self._serial is None:
            raise InstrumentError(self.name, self._action or "use", "not connected")

    def _line_time_s(self) -> float:
        return 40 * 10.0 / self.settings.baudrate        # a 40-character answer on the line

    def _port_lost(self, step: str, error: BaseException) -> InstrumentError:
        """The typed error of a serial ``step`` that failed: a write timeout, else the port gone."""
        if isinstance(error, serial.SerialTimeoutException):
            return InstrumentTimeout(self.name, self._action, f"{step} timed out: {error}")
        return TransportLost(self.name, self._action, transport_reason(error),
                             what=f"serial port {self.settings.port} lost ({step} failed)")

    def _write(self, data: bytes) -> None:
        try:
            self._serial.write(data)
        except _PORT_ERRORS as exc:
            raise self._port_lost("write", exc) from exc

    def _flush_input(self) -> None:
        self._pending.clear()
        try:
            self._serial.reset_input_buffer()
        except _PORT_ERRORS as exc:
            raise self._port_lost("flush", exc) from exc

    def _read_line(self, deadline: float) -> str:
        """Next non-empty line (terminated by CR or LF), printable characters only."""
        while True:
            for index, byte in enumerate(self._pending):
                if byte in b"\r\n":
                    raw = bytes(self._pending[:index])
                    del self._pending[:index + 1]
                    line = raw.translate(None, _NON_PRINTABLE)
                    if line.strip():
                        return line.decode("ascii").strip()
                    break
            else:
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    partial = bytes(self._pending)
                    raise InstrumentTimeout(self.name, self._action,
                                            f"no complete answer within {self.timeout_s} s"
                                            + (f" (partial {partial!r})" if partial else ""))
                try:
                    self._serial.timeout = min(remaining, 0.05)
                    chunk = self._serial.read(max(1, self._serial.in_waiting))
                except _PORT_ERRORS as exc:
                    raise self._port_lost("read", exc) from exc
                self._pending += chunk
