"""Driver of the bench DAQ over Modbus TCP or RTU (pymodbus client).

The DAQ captures the phase currents, the encoder counter, the transducer's analog torque and the
dc-bus voltage synchronously, and drives the dyno's speed reference from an analog output. Its
registers are described by a data file (``drivers/data/daq_registers.toml``, see
``ripple_hil_drivers.daq_register_map``). A capture: configure (sample rate, samples, channel mask, settle
time, capture format) -> arm -> trigger -> poll the state until "done" -> read the buffer out in
125-register windows -> check its integrity -> convert to engineering units -> disarm. The result
is a ``hil.capture.Capture`` with ``time_s`` (from the trigger, by the sample clock's ticks), the
channels asked for (default all: ``ia_a``, ``ib_a``, ``encoder_counts`` (the 32-bit counter
unwrapped) with ``rotor_angle_mech_rad`` (= counts * 2*pi / counts_per_rev), ``torque_nm``,
``dc_bus_v``) and ``sample_counter`` (sample-clock ticks since the first sample);
``meta["daq_lsb"]`` gives each channel's LSB in SI units for the uncertainty budget (int16
channels: the map's scale; the angle: 2*pi / counts_per_rev) and ``meta["daq_transfer"]`` how the
data travelled (mode, requests, round trips).

Transfer (issue 17, :class:`TransferOptions`): only the channels asked for; the buffer read with
auto-increment when the map offers it (one request per 125 words instead of a page write plus a
read), up to ``in_flight`` reads outstanding over TCP (``ripple_hil_drivers.modbus_pipeline``), the packed
capture format (the encoder counter's low word) when the counter cannot move half its 16-bit
range between samples. ``LEGACY_TRANSFER`` is the old way (paged, one at a time, full format).
A readout that loses an answer or the connection is read again once (the DAQ keeps its buffer
until disarmed); a Modbus exception is not retried.

Integrity (issue 13): every capture is checked: the samples received equal the samples requested,
the rate read back equals the rate asked, and the sample counter advances by exactly one tick per
sample (a uniform time base). A failure raises :class:`CaptureIntegrityError` naming the DAQ and
what was wrong, with the data as received attached (``error.capture``) so the caller can save it.

Modbus exception codes become typed errors (all ``DeviceFault``): ``IllegalFunction`` (1),
``IllegalAddress`` (2), ``IllegalValue`` (3), ``DeviceFailure`` (4), ``DeviceBusy`` (6); no answer
is ``InstrumentTimeout``; a link that cannot be made or breaks (refused, reset, closed, serial port
gone) is ``TransportLost`` with the operating system's reason, raised from the original. Each
message says which instrument and what the driver was doing.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from dataclasses import dataclass

import numpy as np
from pymodbus import FramerType, ModbusException
from pymodbus.exceptions import ConnectionException, ModbusIOException
from pymodbus.pdu.file_message import FileRecord

from ripple_hil_drivers import modbus_pipeline
from ripple_hil_drivers.modbus_link import SerialClient, TcpClient, connect_reason
from ripple_hil_drivers.daq_register_map import Channel, RegisterMap, load_register_map
from ripple_hil_drivers.serial_line import PARITIES, STOPBITS, line_for_port
from ripple_hil_drivers.errors import (ChannelClippedError, DeviceFault, InstrumentError,
                                      InstrumentTimeout, ProtocolError, TransportLost,
                                      transport_reason)
from hil.capture import Capture
from hil.errors import InputError


@dataclass(frozen=True)
class ModbusTcpSettings:
    """Modbus TCP endpoint of the DAQ."""

    host: str = "127.0.0.1"
    port: int = 502


@dataclass(frozen=True)
class ModbusRtuSettings:
    """Modbus RTU serial line of the DAQ: 8 data bits, ``parity`` E/O/N, ``stopbits`` 1/2
    (default 8E1, the Modbus serial-line default)."""

    port: str
    baudrate: int = 115200
    parity: str = "E"
    stopbits: int = 1

    def __post_init__(self) -> None:
        if self.parity not in PARITIES:
            raise InputError(f"daq parity={self.parity!r}; allowed {', '.join(PARITIES)}")
        if self.stopbits not in STOPBITS:
            raise InputError(f"daq stopbits={self.stopbits!r}; allowed 1 or 2")


@dataclass(frozen=True)
class TransferOptions:
    """How a capture buffer travels (issue 17). ``read_mode``: "best" (auto-increment if the
    map offers it, else paged), "paged" or "auto_increment"; ``in_flight``: reads outstanding
    over TCP (RTU: always 1); ``packed``: use the map's packed capture format when safe;
    ``sample_counter``: capture the time-base channel (needed for the time-base check)."""

    read_mode: str = "best"
    in_flight: int = 8
    packed: bool = True
    sample_counter: bool = True

    def __post_init__(self) -> None:
        if self.read_mode not in ("best", "paged", "auto_increment"):
            raise InputError(f"daq read_mode={self.read_mode!r}; allowed best, paged, "
                             f"auto_increment")
        if not 1 <= self.in_flight <= 64:
            raise InputError(f"daq in_flight={self.in_flight}; allowed 1..64")


#: The transfer before issue 17: a page write before every window read, one request at a time,
#: the full format, no sample counter.
LEGACY_TRANSFER = TransferOptions(read_mode="paged", in_flight=1, packed=False,
                                  sample_counter=False)
#: Capture channel names a caller may ask for besides the map's: the angle comes from the encoder.
_ALIASES = {"rotor_angle_mech_rad": "encoder_counts"}


class CaptureIntegrityError(DeviceFault):
    """A finished capture is not what was asked: samples missing or a non-uniform time base.

    ``capture`` holds the data as received (time from the sample counter where there is one),
    ``problems`` each finding; the caller saves the raw data before handling the error.
    """

    def __init__(self, instrument: str, problems: list[str], capture: Capture) -> None:
        super().__init__(instrument, "check capture integrity", "; ".join(problems))
        self.problems = problems
        self.capture = capture


class ModbusExceptionError(DeviceFault):
    """The DAQ answered a Modbus exception response; ``code`` is the exception code."""

    code = 0


class IllegalFunction(ModbusExceptionError):
    code = 1


class IllegalAddress(ModbusExceptionError):
    code = 2


class IllegalValue(ModbusExceptionError):
    code = 3


class DeviceFailure(ModbusExceptionError):
    code = 4


class DeviceBusy(ModbusExceptionError):
    code = 6


_EXCEPTIONS = {cls.code: cls for cls in (IllegalFunction, IllegalAddress, IllegalValue,
                                         DeviceFailure, DeviceBusy)}
_EXCEPTION_TEXT = {1: "illegal function", 2: "illegal data address", 3: "illegal data value",
                   4: "server device failure", 5: "acknowledge", 6: "server device busy"}
POLL_INTERVAL_S = 0.002
#: The ends of a channel's int16 range: a sample there may have been clipped.
INT16_MAX, INT16_MIN = 32767, -32768
log = logging.getLogger(__name__)


def exception_error(instrument: str, action: str, code: int) -> ModbusExceptionError:
    """The typed error for a Modbus exception code."""
    cls = _EXCEPTIONS.get(code, ModbusExceptionError)
    error = cls(instrument, action, f"Modbus exception {code} "
                                    f"({_EXCEPTION_TEXT.get(code, 'unknown')})")
    error.code = code
    return error


class ModbusDaq:
    """Bench DAQ on Modbus; use as a context manager or call ``connect()`` / ``close()``."""

    def __init__(self, settings: ModbusTcpSettings | ModbusRtuSettings, unit_id: int = 1,
                 register_map: RegisterMap | str | None = None, timeout_s: float = 1.0,
                 instrument_name: str = "daq",
                 transfer: TransferOptions = TransferOptions()) -> None:
        if not 0 <= unit_id <= 247:
            raise InputError(f"daq unit_id={unit_id} outside 0..247")
        if not timeout_s > 0:
            raise InputError(f"daq timeout_s={timeout_s} must be > 0")
        self.settings = settings
        self.unit_id = unit_id
        self.map = register_map if isinstance(register_map, RegisterMap) \
            else load_register_map(register_map)
        self.timeout_s = timeout_s
        self.name = instrument_name
        self.transfer = transfer
        self._lock = threading.RLock()
        self._identity: dict | None = None
        self._round_trips = 0
        self.line_note = ""         # RTU on a pseudo-terminal: why parity is not applied
        self._tid = 0x8000           # pipelined transaction ids (pymodbus counts from 0)
        if isinstance(settings, ModbusTcpSettings):
            self._client = TcpClient(settings.host, port=settings.port, timeout=timeout_s,
                                           retries=0, reconnect_delay=0.0)
        elif isinstance(settings, ModbusRtuSettings):
            parity, self.line_note = line_for_port(settings.port, settings.parity)
            self._client = SerialClient(settings.port, framer=FramerType.RTU,
                                        baudrate=settings.baudrate, bytesize=8, parity=parity,
                                        stopbits=settings.stopbits, timeout=timeout_s,
                                        retries=0, reconnect_delay=0.0)
        else:
            raise InputError(f"daq settings must be ModbusTcpSettings or ModbusRtuSettings, "
                             f"got {type(settings).__name__}")

    # ------------------------------------------------------------------ connection
    def connect(self) -> "ModbusDaq":
        with self._lock:
            if not self._client.connect():
                raise TransportLost(self.name, "connect", connect_reason(self._client),
                                    what=f"cannot connect to {self.endpoint}") \
                    from self._client.connect_error
        return self

    @property
    def endpoint(self) -> str:
        """Where the DAQ is: "host:port" (TCP) or the serial port (RTU)."""
        if isinstance(self.settings, ModbusTcpSettings):
            return f"{self.settings.host}:{self.settings.port}"
        return self.settings.port

    def _lost(self, action: str, error: BaseException) -> TransportLost:
        """The typed error of a link that broke (or could not be re-made) during ``action``,
        caused by the OS error of the failed reconnection, else by ``error``."""
        if getattr(self._client, "socket", None) is None and self._client.connect_error:
            lost = TransportLost(self.name, action, connect_reason(self._client),
                                 what=f"connection lost, cannot reconnect to {self.endpoint}")
            lost.__cause__ = self._client.connect_error
        elif isinstance(error, ConnectionException) and "unexpectedly closed" in str(error) \
                and not isinstance(error.__context__, OSError):
            lost = TransportLost(self.name, action, f"{self.endpoint} closed the connection "
                                                    f"without answering")
        else:
            lost = TransportLost(self.name, action, transport_reason(error))
        lost.__cause__ = lost.__cause__ or error
        return lost

    def close(self) -> None:
        with self._lock:
            self._client.close()

    def __enter__(self) -> "ModbusDaq":
        return self.connect()

    def __exit__(self, *exc) -> None:
        self.close()

    # ------------------------------------------------------------------ register access
    def _call(self, action: str, request, *args, **kwargs):
        with self._lock:
            self._round_trips += 1
            try:
                response = request(*args, device_id=self.unit_id, **kwargs)
            except ConnectionException as exc:
                raise self._lost(action, exc)       # noqa: B904 - _lost sets the cause
            except ModbusIOException as exc:
                raise InstrumentTimeout(self.name, action,
                                        f"no answer within {self.timeout_s} s ({exc})") from exc
            except ModbusException as exc:
                raise InstrumentError(self.name, action, str(exc)) from exc
            except OSError as exc:          # a socket or serial error pymodbus let through
                self._client.close()
                raise self._lost(action, exc)       # noqa: B904 - _lost sets the cause
        if response.isError():
            code = getattr(response, "exception_code", 0)
            raise exception_error(self.name, action, code)
        asked, got = kwargs.get("count"), getattr(response, "registers", None)
        if asked is not None and got is not None and len(got) != asked:
            raise ProtocolError(self.name, action, f"asked for {asked} registers, got {len(got)}")
        return response

    def read_registers(self, *names: str) -> dict:
        """Read named registers of one table in one request (they must span a contiguous,
        mapped range) and decode them."""
        regs = [self.map[name] for name in names]
        tables = {reg.table for reg in regs}
        if len(tables) != 1:
            raise InputError(f"read_registers: {names} mix register tables {sorted(tables)}")
        first = min(reg.address for reg in regs)
        count = max(reg.address + reg.words for reg in regs) - first
        request = (self._client.read_input_registers if regs[0].table == "input"
                   else self._client.read_holding_registers)
        response = self._call(f"read {', '.join(names)}", request, first, count=count)
        words = response.registers
        return {reg.name: reg.decode(words[reg.address - first:reg.address - first + reg.words])
                for reg in regs}

    def write_registers(self, **values) -> None:
        """Write named holding registers that form one contiguous range, in one request."""
        regs = sorted((self.map[name] for name in values), key=lambda reg: reg.address)
        if any(reg.table != "holding" for reg in regs):
            raise InputError(f"write_registers: {sorted(values)} are not all holding registers")
        words: list[int] = []
        for before, reg in zip([None, *regs], regs):
            if before is not None and before.address + before.words != reg.address:
                raise InputError(f"write_registers: {before.name} and {reg.name} not contiguous")
            words += reg.encode(values[reg.name])
        action = "write " + ", ".join(f"{reg.name}={values[reg.name]}" for reg in regs)
        if len(words) == 1:
            self._call(action, self._client.write_register, regs[0].address, words[0])
        else:
            self._call(action, self._client.write_registers, regs[0].address, words)

    # ------------------------------------------------------------------ identity, dyno
    def identity(self) -> dict:
        """Model, serial number, firmware and the device constants the analysis needs."""
        info = self.read_registers("model", "serial_number", "firmware", "map_version",
                                   "encoder_counts_per_rev", "pole_pairs",
                                   "buffer_capacity_samples", "max_sample_rate_hz")
        self._identity = info
        return dict(info)

    def _device_constants(self) -> dict:
        return self._identity if self._identity is not None else self.identity()

    def set_dyno_speed_rpm(self, rpm: float) -> None:
        """Set the dyno's speed reference (the DAQ's analog output), rpm."""
        reg = self.map["dyno_speed_setpoint_rpm"]
        if not (math.isfinite(rpm) and reg.minimum <= rpm <= reg.maximum):
            raise InputError(f"dyno speed_rpm={rpm} outside {reg.minimum}..{reg.maximum} rpm")
        self.write_registers(dyno_speed_setpoint_rpm=float(rpm))

    def dyno_speed_rpm(self) -> float:
        """The dyno speed reference the DAQ outputs now, rpm."""
        return float(self.read_registers("dyno_speed_setpoint_rpm")["dyno_speed_setpoint_rpm"])

    # ------------------------------------------------------------------ capture, low level
    def resolution(self) -> dict[str, float]:
        """LSB of each channel in SI units (for the uncertainty budget)."""
        lsb = {channel.name: channel.scale for channel in self.map.channels}
        counts = int(self._device_constants()["encoder_counts_per_rev"])
        lsb["rotor_angle_mech_rad"] = 2.0 * math.pi / counts
        return lsb

    def arm(self, sample_rate_hz: float, samples: int, settle_s: float = 0.05,
            channels=None, packed: bool = False) -> None:
        """Configure a capture (integer Hz, sample count, DAQ channels (default all), settle
        time, packed format if the map offers it) and arm it."""
        rate = int(round(sample_rate_hz))
        device = self.map.device
        if abs(rate - sample_rate_hz) > 1e-9 * max(1.0, sample_rate_hz) or \
                not 1 <= rate <= int(device["max_sample_rate_hz"]):
            raise InputError(f"daq sample_rate_hz={sample_rate_hz} must be a whole number "
                             f"of Hz in 1..{device['max_sample_rate_hz']}")
        if int(samples) < 1:
            raise InputError(f"daq samples={samples} must be >= 1")
        settle_ms = int(round(settle_s * 1000.0))
        if not 0 <= settle_ms <= int(device["max_settle_ms"]):
            raise InputError(f"daq settle_s={settle_s} outside 0..{device['max_settle_ms']} ms")
        names = [c.name for c in self.map.channels] if channels is None else list(channels)
        config = {"sample_rate_hz": rate, "samples": int(samples),
                  "channel_mask": self.map.mask_of(names), "settle_ms": settle_ms}
        if self.map.offers_packed:
            config["capture_format"] = self.map.capture_formats["packed" if packed else "full"]
        elif packed:
            raise InputError(f"daq: the register map {self.map.source} offers no packed format")
        self.write_registers(**config)
        self.write_registers(control=self.map.control_codes["arm"])

    def trigger(self) -> None:
        """Start the armed capture (software trigger)."""
        self.write_registers(control=self.map.control_codes["trigger"])

    def disarm(self) -> None:
        """Abort or finish a capture; the DAQ returns to idle."""
        self.write_registers(control=self.map.control_codes["disarm"])

    def status(self) -> dict:
        """State name, overrun and clipped flags, samples captured, words per sample."""
        raw = self.read_registers("state", "status_flags", "samples_captured",
                                  "words_per_sample")
        flags = raw["status_flags"]
        return {"state": self.map.state_name(raw["state"]),
                "overrun": bool(flags >> self.map.status_flags["overrun"] & 1),
                "clipped": bool(flags >> self.map.status_flags["clipped"] & 1),
                "samples_captured": raw["samples_captured"],
                "words_per_sample": raw["words_per_sample"]}

    def wait_done(self, timeout_s: float) -> dict:
        """Poll until the capture is done; DeviceFault on fault or overrun, timeout -> error."""
        deadline = time.monotonic() + timeout_s
        while True:
            status = self.status()
            if status["state"] == "done":
                break
            if status["state"] != "capturing":
                raise DeviceFault(self.name, "wait for capture",
                                  f"DAQ state is {status['state']!r}, not capturing")
            if time.monotonic() > deadline:
                raise InstrumentTimeout(self.name, "wait for capture",
                                        f"not done within {timeout_s} s")
            time.sleep(POLL_INTERVAL_S)
        if status["overrun"]:
            capacity = self._device_constants()["buffer_capacity_samples"]
            raise DeviceFault(self.name, "capture", f"buffer overrun: asked more samples than "
                                                    f"the buffer holds ({capacity})")
        return status

    def read_buffer(self, samples_requested: int | None = None,
                    rate_requested_hz: float | None = None) -> Capture:
        """Read the finished capture out, convert it to engineering units and check it.

        The check compares with the configuration read back from the DAQ, and with
        ``samples_requested`` / ``rate_requested_hz`` when given; a failure raises
        :class:`CaptureIntegrityError` carrying the data.
        """
        round_trips_before = self._round_trips
        status = self.status()
        if status["state"] != "done":
            raise DeviceFault(self.name, "read capture buffer",
                              f"DAQ state is {status['state']!r}, no finished capture")
        names = ["sample_rate_hz", "samples", "channel_mask", "settle_ms"]
        if self.map.offers_packed:
            names.append("capture_format")
        config = self.read_registers(*names)
        packed = self.map.offers_packed and \
            config.get("capture_format") == self.map.capture_formats.get("packed")
        channels = self.map.channels_in(config["channel_mask"])
        n, words_per_sample = status["samples_captured"], status["words_per_sample"]
        expected_words = self.map.frame_words(channels, packed)
        if words_per_sample != expected_words:
            raise DeviceFault(self.name, "read capture buffer",
                              f"device frame has {words_per_sample} words, map says "
                              f"{expected_words} for mask {config['channel_mask']:#x}"
                              f"{' (packed)' if packed else ''}")
        first_values = {}
        if packed:
            registers = [c.packed_first_register for c in channels if c.packed_first_register]
            first_values = self.read_registers(*registers) if registers else {}
        mode, depth, requests = self._read_plan(n * words_per_sample)
        words, retried = self._read_words_retrying(n * words_per_sample, mode, depth)
        frames = words.reshape(n, words_per_sample)
        capture, problems = self._to_capture(frames, channels, packed, first_values,
                                             float(config["sample_rate_hz"]),
                                             config["settle_ms"] / 1000.0, status["clipped"])
        capture.meta["daq_transfer"] = {
            "read_mode": mode, "in_flight": depth, "packed": packed,
            "words_per_sample": words_per_sample, "buffer_requests": requests,
            "round_trips_readout": self._round_trips - round_trips_before,
            "readout_retried_after": retried}
        wanted = config["samples"] if samples_requested is None else int(samples_requested)
        if n != wanted or config["samples"] != wanted:
            problems.insert(0, f"asked for {wanted} samples, the DAQ was set to "
                               f"{config['samples']} and returned {n}")
        if rate_requested_hz is not None and config["sample_rate_hz"] != rate_requested_hz:
            problems.append(f"asked for {rate_requested_hz} Hz, the DAQ sampled at "
                            f"{config['sample_rate_hz']} Hz")
        capture.meta["daq_integrity"] = {"checked_time_base": self.map.sample_counter in channels,
                                         "problems": list(problems)}
        if problems:
            raise CaptureIntegrityError(self.name, problems, capture)
        return capture

    def _read_plan(self, total: int) -> tuple[str, int, int]:
        """(read mode, requests in flight, buffer requests) for ``total`` words."""
        mode = self.transfer.read_mode
        if self.map.transfer.kind == "file_record":
            if mode != "best":
                raise InputError(f"daq read_mode={mode!r}: the register map {self.map.source} "
                                 "reads its buffer with Read File Record (0x14)")
            return "file_record", 1, len(self.map.transfer.requests(total))
        if mode == "best":
            mode = "auto_increment" if self.map.offers_auto_increment else "paged"
        elif mode == "auto_increment" and not self.map.offers_auto_increment:
            raise InputError(f"daq read_mode='auto_increment': the register map "
                             f"{self.map.source} offers only paged reads")
        depth = self.transfer.in_flight if isinstance(self.settings, ModbusTcpSettings) else 1
        return mode, depth, -(-total // self.map.window_words)

    def _read_words_retrying(self, total: int, mode: str, depth: int) -> tuple[np.ndarray, str]:
        """The buffer's words, and why the readout was repeated ("" if it was not).

        A lost answer or connection mid-readout is retried once from the first word: the DAQ
        keeps the buffer until it is disarmed, so a flaky link does not lose the capture. A
        Modbus exception (the DAQ refusing) is not retried.
        """
        try:
            return self._read_words(total, mode, depth), ""
        except InstrumentTimeout as exc:
            reason = str(exc)
        except InstrumentError as exc:
            if isinstance(exc, (DeviceFault, ProtocolError)):
                raise
            reason = str(exc)
        log.warning("%s: readout failed (%s); reading the buffer again", self.name, reason)
        return self._read_words(total, mode, depth), reason

    def _read_words(self, total: int, mode: str = "paged", depth: int = 1) -> np.ndarray:
        if mode == "file_record":
            return self._read_file_records(total)
        window = self.map["buffer_window"]
        out = np.empty(total, dtype=np.uint16)
        counts = [min(window.words, total - begin) for begin in range(0, total, window.words)]
        if mode == "paged":
            if "buffer_read_mode" in self.map.registers:
                self.write_registers(buffer_read_mode=self.map.buffer_read_modes["paged"])
            for page, count in enumerate(counts):
                self.write_registers(buffer_page=page)
                response = self._call(f"read capture buffer page {page}",
                                      self._client.read_input_registers, window.address,
                                      count=count)
                out[page * window.words:page * window.words + count] = response.registers
            return out
        # selecting the mode rewinds the read pointer to the first word
        self.write_registers(buffer_read_mode=self.map.buffer_read_modes["auto_increment"])
        if depth > 1:
            chunks = self._pipelined(window.address, counts, depth)
        else:
            chunks = [self._call(f"read capture buffer window {i} (auto-increment)",
                                 self._client.read_input_registers, window.address,
                                 count=count).registers for i, count in enumerate(counts)]
        for i, chunk in enumerate(chunks):
            out[i * window.words:i * window.words + len(chunk)] = chunk
        return out

    def _read_file_records(self, total: int) -> np.ndarray:
        """The buffer by the standard Read File Record function (0x14), one sub-request per
        request as the map's ``[transfer]`` lays the words out in files and records."""
        out = np.empty(total, dtype=np.uint16)
        word = 0
        for file, record, count in self.map.transfer.requests(total):
            response = self._call(f"read capture buffer file {file} record {record} "
                                  f"({count} words, Read File Record)",
                                  self._client.read_file_record,
                                  [FileRecord(file_number=file, record_number=record,
                                              record_length=2 * count)])
            data = b"".join(r.record_data for r in response.records)
            if len(response.records) != 1 or len(data) != 2 * count:
                raise ProtocolError(self.name, f"read file {file} record {record}",
                                    f"asked for {count} registers in one record group, got "
                                    f"{len(data) // 2} in {len(response.records)}")
            out[word:word + count] = np.frombuffer(data, dtype=">u2")
            word += count
        return out

    def _pipelined(self, address: int, counts: list[int], depth: int) -> list[np.ndarray]:
        """Buffer windows with ``depth`` reads in flight on the TCP connection."""
        action = f"read capture buffer ({len(counts)} windows, {depth} in flight)"
        with self._lock:
            sock = getattr(self._client, "socket", None)
            if sock is None and not self._client.connect():
                raise TransportLost(self.name, action, connect_reason(self._client),
                                    what=f"not connected, cannot reconnect to {self.endpoint}") \
                    from self._client.connect_error
            sock = self._client.socket
            first_tid, self._tid = self._tid, 0x8000 + (self._tid + len(counts)) % 0x8000
            self._round_trips += -(-len(counts) // depth)
            try:
                return modbus_pipeline.read_input_registers_pipelined(
                    sock, self.unit_id, address, counts, depth=depth, timeout_s=self.timeout_s,
                    first_tid=first_tid)
            except modbus_pipeline.ExceptionAnswer as exc:
                self._client.close()        # later answers may still be on their way
                raise exception_error(self.name, f"{action}, window {exc.index}",
                                      exc.code) from exc
            except TimeoutError as exc:
                self._client.close()
                raise InstrumentTimeout(self.name, action, f"{exc} ({self.timeout_s} s)") \
                    from exc
            except modbus_pipeline.UnexpectedAnswer as exc:
                self._client.close()
                raise InstrumentError(self.name, action, f"connection dropped: {exc}") from exc
            except OSError as exc:          # ConnectionError included
                self._client.close()
                raise self._lost(action, exc)       # noqa: B904 - _lost sets the cause

    def _to_capture(self, frames, channels, packed, first_values, rate, settle_s,
                    clipped) -> tuple[Capture, list[str]]:
        """Engineering units, and the integrity problems found while decoding."""
        constants = self._device_constants()
        counts_per_rev = int(constants["encoder_counts_per_rev"])
        n = len(frames)
        data, lsb, problems, at_rail = {}, {}, [], []
        ticks = None
        column = 0
        counter = self.map.sample_counter
        for channel in channels:
            width = channel.words_in(packed)
            raw = channel.from_words(frames[:, column:column + width], packed)
            column += width
            if counter is not None and channel.name == counter.name:
                ticks = unwrap_counter(raw, channel.counter_bits)
                ticks = ticks - ticks[0] if n else ticks
                data[channel.name] = ticks
                problems += _time_base_problems(ticks, rate)
            elif channel.is_counter:
                counts = self._counter_counts(channel, raw, packed, first_values, problems)
                data[channel.name] = counts
                data["rotor_angle_mech_rad"] = counts * (2.0 * math.pi / counts_per_rev)
                lsb[channel.name] = 1.0
                lsb["rotor_angle_mech_rad"] = 2.0 * math.pi / counts_per_rev
            else:
                data[channel.name] = raw * channel.scale + channel.offset
                lsb[channel.name] = channel.scale
                if clipped and (np.any(raw >= INT16_MAX) or np.any(raw <= INT16_MIN)):
                    at_rail.append(channel.name)
        data = {"time_s": (ticks if ticks is not None else np.arange(n)) / rate} | data
        meta = {"source": "daq", "instrument": self.name, "sample_rate_hz": rate,
                "encoder_counts_per_rev": counts_per_rev,
                "pole_pairs": int(constants["pole_pairs"]), "daq_lsb": lsb,
                "daq_model": constants["model"], "daq_serial_number": constants["serial_number"],
                "daq_settle_s": settle_s, "daq_clipped": bool(clipped),
                "daq_clipped_channels": at_rail}
        if self.line_note:
            meta["daq_line_note"] = self.line_note
        return Capture(channels=data, meta=meta), problems

    @staticmethod
    def _counter_counts(channel: Channel, raw, packed, first_values, problems) -> np.ndarray:
        """A counter channel unwrapped; a packed one re-anchored on its first full value."""
        if not (packed and channel.packed_first_register):
            return unwrap_counter(raw, channel.counter_bits)
        first = int(first_values[channel.packed_first_register])
        if len(raw) and raw[0] != first & 0xFFFF:
            problems.append(f"{channel.name}: packed first sample {int(raw[0])} is not the low "
                            f"word of {channel.packed_first_register} = {first}")
        low = unwrap_counter(raw, 16)
        anchor = unwrap_counter(np.array([first]), channel.counter_bits)[0]
        return anchor + (low - low[0]) if len(raw) else low

    # ------------------------------------------------------------------ capture, high level
    def capture(self, duration_s: float, sample_rate_hz: float, settle_s: float = 0.05,
                timeout_s: float | None = None, channels=None) -> Capture:
        """Configure, arm, trigger, wait, read, check and disarm; the capture in SI units.

        ``channels``: the capture channels wanted (map names, or ``rotor_angle_mech_rad`` for
        the encoder); None: all of them. Raises ChannelClippedError (a LimitError) naming the
        channels if any clipped (the capture would understate the ripple), CaptureIntegrityError if samples are missing or the time
        base is not uniform.
        """
        if not (math.isfinite(duration_s) and duration_s > 0):
            raise InputError(f"daq duration_s={duration_s} must be > 0")
        samples = int(round(duration_s * sample_rate_hz))
        capacity = int(self._device_constants()["buffer_capacity_samples"])
        if not 1 <= samples <= capacity:
            raise InputError(f"daq capture of duration_s={duration_s} at sample_rate_hz="
                             f"{sample_rate_hz} is {samples} samples; allowed 1..{capacity}")
        if timeout_s is None:
            timeout_s = 10.0 + 20.0 * (duration_s + settle_s)
        names = self.capture_channels(channels)
        packed = self._packing_is_safe(names, sample_rate_hz)
        round_trips = self._round_trips
        try:
            self.arm(sample_rate_hz, samples, settle_s, names, packed)
            self.trigger()
            setup = self._round_trips - round_trips
            self.wait_done(timeout_s)
            polls = self._round_trips - round_trips - setup
            result = self.read_buffer(samples, round(sample_rate_hz))
        finally:
            self._disarm_quietly()
        result.meta["daq_transfer"].update(round_trips_setup=setup + 1, round_trips_polling=polls)
        if result.meta["daq_clipped"]:
            names = result.meta["daq_clipped_channels"]
            lsb = result.meta["daq_lsb"]
            which = ", ".join(f"{name} (±{32767 * lsb[name]:.4g} at LSB {lsb[name]:g})"
                              for name in names) or "a channel (the DAQ did not say which)"
            raise ChannelClippedError(self.name, "capture",
                                      f"{which} hit the end of its int16 range", names)
        return result

    def capture_channels(self, channels=None) -> list[str]:
        """The DAQ channels a capture of ``channels`` (None: all) reads, in map order, with the
        sample counter when the transfer options ask for it."""
        wanted = {c.name for c in self.map.channels} if channels is None else \
            {_ALIASES.get(name, name) for name in channels}
        counter = self.map.sample_counter
        if counter is not None:
            if self.transfer.sample_counter:
                wanted.add(counter.name)
            elif channels is None:
                wanted.discard(counter.name)
        for name in wanted:
            self.map.channel(name)      # InputError naming the unknown channel
        return [c.name for c in self.map.channels if c.name in wanted]

    def _packing_is_safe(self, names: list[str], sample_rate_hz: float) -> bool:
        """Packed format when asked, offered, and no packed counter can move half its 16-bit
        range in one sample (the encoder at the dyno's top speed)."""
        if not (self.transfer.packed and self.map.offers_packed):
            return False
        counts_per_rev = int(self._device_constants()["encoder_counts_per_rev"])
        top_rpm = max(abs(self.map["dyno_speed_setpoint_rpm"].minimum or 0.0),
                      abs(self.map["dyno_speed_setpoint_rpm"].maximum or 0.0))
        counts_per_sample = top_rpm / 60.0 * counts_per_rev / sample_rate_hz
        packs = any(self.map.channel(name).packed_type for name in names)
        return packs and counts_per_sample < 2 ** 15

    def _disarm_quietly(self) -> None:
        try:
            self.disarm()
        except InstrumentError:
            pass    # the original error (if any) matters more; the guard disarms again


def _time_base_problems(ticks: np.ndarray, rate_hz: float) -> list[str]:
    """Findings if the sample-clock ticks do not advance by exactly one per sample."""
    steps = np.diff(ticks)
    bad = np.flatnonzero(steps != 1)
    if not len(bad):
        return []
    lost = int(np.sum(steps[bad] - 1))
    return [f"time base not uniform at {rate_hz:g} Hz: the sample counter skips at "
            f"{len(bad)} of {len(steps)} steps (first after sample {int(bad[0])}, by "
            f"{int(steps[bad[0]])} ticks; {lost} samples lost in all)"]


def unwrap_counter(raw: np.ndarray, bits: int = 32) -> np.ndarray:
    """Unwrap a free-running ``bits``-bit counter into signed int64 counts.

    The first sample is read as a two's-complement value; each step is taken modulo 2**bits
    into -2**(bits-1)..2**(bits-1)-1 (the counter may not move more than half its range between
    samples).
    """
    raw = np.asarray(raw, dtype=np.int64)
    if raw.size == 0:
        return raw
    modulus, half = 1 << bits, 1 << (bits - 1)
    first = raw[0] - modulus if raw[0] >= half else raw[0]
    steps = (np.diff(raw) + half) % modulus - half
    return first + np.concatenate(([0], np.cumsum(steps)))
