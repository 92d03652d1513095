"""Simulated Modbus DAQ (TCP or RTU over a pseudo-terminal), backed by a ``hil.sim.DriveTwin``.

``DaqDevice`` holds the registers of ``drivers/data/daq_registers.toml`` and answers each request
exactly as the map's header says: function codes 3, 4, 6, 16 only (others: exception 1), no coils
or discrete inputs (exception 2), unlisted addresses exception 2, configuration writes validated
(exception 3) and refused while a capture runs (exception 6); the buffer is read paged or with
auto-increment (``buffer_read_mode``), in the full or packed ``capture_format``. A pymodbus server
(``SimDevice`` action hook) carries it over TCP or RTU; any other server implementation can call
``DaqDevice.handle`` (the tests serve it with modbus-tk). A map whose ``[transfer]`` is
``file_record`` (another vendor's DAQ, e.g. ``drivers/data/daq_file_record_example.toml``) is
served too: its buffer answers Read File Record (0x14, ``DaqDevice.read_file_record``), its
registers by their roles (``[roles]``); on the shipped map 0x14 stays exception 1.

A capture runs in simulated time in a worker thread: under the twin's lock it calls
``twin.advance(settle_s, rate, channels=())`` (nothing recorded), waits for the drive's next PWM
counter valley (``twin.advance_to_carrier_valley``, less than one PWM period) and then calls
``twin.advance(n / rate, rate, channels=...)`` asking only for the enabled channels, and stores
their scaled int16 / uint32 words, and the sample-clock tick of each sample in
the ``sample_counter`` channel.

Sample clock and PWM carrier: the simulated DAQ's first sample falls on a PWM counter valley
(its sample clock is synchronised to the drive's carrier, as with a DAQ triggered from the
drive's PWM sync output). The phase of the samples within the PWM period matters wherever the
sample rate is commensurate with f_pwm (8 kHz against 20 kHz hits only two phases): the
switching ripple then aliases into the phase currents' fundamental by up to ±2.7 % at 500 rpm
20 A, depending on that phase. Started at the trigger instant instead, the phase was set by the
simulated time the bench had run (captures and settles that are not whole PWM periods, PWM
frequency changes), so a long-lived ``hil sim-bench`` drifted from run to run (issue 22.1).
``pwm_synchronous=False`` gives that free-running behaviour of a software-triggered DAQ on a
real bench, whose phase is arbitrary: a measurement that must not depend on it samples at a
rate incommensurate with f_pwm. Asking for more samples than ``buffer_capacity_samples`` stores a
full buffer and raises the overrun flag. The twin's test-only defect ``daq_drop_every_nth``
(``hil.sim.defects``) makes the DAQ silently lose every n-th sample (see :func:`stored_ticks`). The holding
register pair ``dyno_speed_setpoint_rpm`` is the DAQ's analog output to the dyno: writing it sets
``twin.speed_rpm`` (if a capture is running, the dyno takes the new speed when that capture's
simulation window ends: the twin changes operating point only between ``advance`` calls).

RTU: ``SimulatedDaq.rtu(twin, parity=, stopbits=)`` (default 8E1, the Modbus serial-line default)
opens two pseudo-terminals in raw mode; the pymodbus serial server listens on one with those line
settings, a bridge thread copies bytes between the two master ends (pacing them to the baud rate
and the bits per character when ``pace_baud`` is set, since a pty ignores both), and the client
opens ``sim.port``. A Linux pty keeps no parity setting, so a parity mismatch cannot show here.

``fail_next(kind)`` makes the next request fail: "exception" (answer exception 4, server device
failure), "timeout" (no answer), "disconnect" (no answer and the TCP connection is closed; on RTU a
serial line cannot disconnect, so it behaves as "timeout").
"""

from __future__ import annotations

import asyncio
import collections
import logging
import math
import os
import select
import struct
import sys
import threading
import time
import tty
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from pymodbus.constants import ExcCodes
from pymodbus.exceptions import ModbusIOException
from pymodbus.framer import FramerSocket
from pymodbus.pdu import ExceptionResponse
from pymodbus.pdu.file_message import FileRecord, ReadFileRecordRequest, ReadFileRecordResponse
from pymodbus.pdu.register_message import ReadHoldingRegistersResponse, ReadInputRegistersResponse
from pymodbus.server import ModbusSerialServer, ModbusTcpServer
from pymodbus.server.requesthandler import ServerRequestHandler
from pymodbus.simulator import DataType, SimData, SimDevice
from pymodbus.transaction import TransactionManager

from ripple_hil_drivers.daq_register_map import RegisterMap, load_register_map
from ripple_hil_drivers.simulated.register_image import RegisterImage
from ripple_hil_drivers.serial_line import PARITIES, STOPBITS, bits_per_char, line_for_port

log = logging.getLogger(__name__)

FAIL_KINDS = ("exception", "timeout", "disconnect")
#: The longest Modbus TCP ADU, bytes (MBAP header 7 + PDU 253; Messaging on TCP/IP §4.1).
MAX_ADU_BYTES = 260
#: The longest frame a client can send that still reads as a request: MBAP 7 + a write's
#: 6-byte header + the 255 bytes its byte count allows (past the spec's ADU: answered with
#: exception 3, as pymodbus does, not dropped).
LONGEST_REQUEST_BYTES = 7 + 6 + 255
#: How long a speed-setpoint write waits for the twin (a transducer reading holds it briefly).
SPEED_APPLY_WAIT_S = 0.05
_INPUT_FC = 4
_REGISTER_FCS = (3, 4, 6, 16)
_WRITE_FCS = (6, 16)
_READ_FCS = (3, 4)
_BIT_FCS = (1, 2, 5, 15)
#: Function codes pymodbus passes to the device's registers (the device refuses all but 3/4/6/16).
_DATASTORE_FCS = (*_REGISTER_FCS, *_BIT_FCS, 22, 23)
EXC_ILLEGAL_FUNCTION, EXC_ILLEGAL_ADDRESS, EXC_ILLEGAL_VALUE = 1, 2, 3
EXC_DEVICE_FAILURE, EXC_BUSY = 4, 6


class _HoldingWords(ReadHoldingRegistersResponse):
    """A Read Holding Registers answer whose ``registers`` are a ``uint16`` array, encoded at
    once: the same bytes as pymodbus's per-register ``encode`` (byte count, then each word
    big-endian; spec v1.1b3 §6.3), which cost a sixth of the DAQ's time per buffer window."""

    def encode(self) -> bytes:
        words = np.asarray(self.registers, dtype=">u2")
        return bytes((2 * words.size,)) + words.tobytes()


class _InputWords(ReadInputRegistersResponse):
    """A Read Input Registers answer encoded as :class:`_HoldingWords` (spec §6.4)."""

    encode = _HoldingWords.encode


_READ_RESPONSES = {3: _HoldingWords, 4: _InputWords}


class Refusal(Exception):
    """A request the device refuses; ``code`` is the Modbus exception code it answers."""

    def __init__(self, code: int, why: str = "") -> None:
        super().__init__(f"exception {code}{': ' + why if why else ''}")
        self.code = int(code)


@dataclass
class Traffic:
    """Requests the device answered and their PDU bytes (function code + data; a transport adds
    7 bytes of MBAP header on TCP, 3 of address and CRC on RTU), split by whether the DAQ was
    capturing (status polls, which overlap the capture itself on a real bench)."""

    requests: int = 0
    request_pdu_bytes: int = 0
    response_pdu_bytes: int = 0
    requests_while_capturing: int = 0
    pdu_bytes_while_capturing: int = 0

    def add(self, request_bytes: int, response_bytes: int, capturing: bool) -> None:
        self.requests += 1
        self.request_pdu_bytes += request_bytes
        self.response_pdu_bytes += response_bytes
        if capturing:
            self.requests_while_capturing += 1
            self.pdu_bytes_while_capturing += request_bytes + response_bytes


def pdu_sizes(function_code: int, count: int, refused: bool) -> tuple[int, int]:
    """(request, response) PDU bytes of a register request (Modbus Application Protocol
    V1.1b3 §6.3/6.4/6.6/6.12; an exception answer is 2 bytes)."""
    request = 6 + 2 * count if function_code == 16 else 5
    if refused:
        return request, 2
    return request, (2 + 2 * count if function_code in (3, 4) else 5)


class DaqDevice:
    """The DAQ's register behaviour and capture engine, transport independent.

    :meth:`handle` answers one Modbus request exactly as the register map says (its header lists
    the function codes, the exception codes and the buffer read modes); the pymodbus server here
    and any other server implementation (the tests use modbus-tk) call it.
    """

    def __init__(self, twin, register_map: RegisterMap, serial_number: str, *,
                 pwm_synchronous: bool = True, channel_gains: dict | None = None) -> None:
        self.twin = twin
        self.pwm_synchronous = bool(pwm_synchronous)
        #: channel -> the gain its input reads the true signal with (an instrument's gain error,
        #: ``[simulation.actual] daq_voltage_gain``); 1 where not listed
        self.channel_gains = dict(channel_gains or {})
        self.map = register_map
        self.device = register_map.device
        self._lock = threading.Lock()
        self._state = register_map.states["idle"]
        self._flags = 0
        self._config = {"sample_rate_hz": 10000, "samples": 1000,
                        "channel_mask": register_map.all_channels_mask, "settle_ms": 50}
        if register_map.offers_packed:
            self._config["capture_format"] = register_map.capture_formats["full"]
        self._read_mode = register_map.buffer_read_modes.get("paged", 0)
        self._page = 0
        self._pointer = 0
        self._words = np.zeros(0, dtype=np.uint16)
        self._samples_captured = 0
        self._words_per_sample = 0
        self._first_values: dict[str, int] = {}
        self._generation = 0
        self._worker: threading.Thread | None = None
        with twin.lock:
            self._speed_setpoint_rpm = float(twin.speed_rpm)
        self._speed_pending = False
        counts = _twin_setting(twin, "sensors", "encoder_counts_per_rev")
        pole_pairs = _twin_setting(twin, "motor", "parameters", "pole_pairs")
        self._constants = {
            "model": self.device["model"], "serial_number": serial_number,
            "firmware": "1.0.0", "map_version": int(self.device["map_version"]),
            "encoder_counts_per_rev": int(counts or self.device["encoder_counts_per_rev"]),
            "pole_pairs": int(pole_pairs or self.device["pole_pairs"]),
            "buffer_capacity_samples": int(self.device["buffer_capacity_samples"]),
            "max_sample_rate_hz": int(self.device["max_sample_rate_hz"]),
        }
        self._image = {"input": RegisterImage(), "holding": RegisterImage()}
        values = dict(self._constants, **self._config, control=0, buffer_page=0,
                      buffer_read_mode=self._read_mode,
                      dyno_speed_setpoint_rpm=self._speed_setpoint_rpm)
        for reg in register_map.registers.values():
            words = reg.encode(values[reg.name]) if reg.name in values else [0] * reg.words
            self._image[reg.table].define(reg.address, words)
        #: registers refreshed from the device's state on an input read (input registers
        #: only where the read covers them; a map may put them in the holding table)
        self._live_registers = [register_map[name] for name in (
            "state", "status_flags", "samples_captured", "words_per_sample")]
        self.fail_next_kind: str | None = None
        self.traffic = Traffic()

    # ------------------------------------------------------------------ requests
    def handle(self, function_code: int, address: int, count: int,
               values: list[int] | None = None) -> list[int] | None:
        """One request: the words read (function codes 3, 4) or None (6, 16); raises Refusal.
        ``traffic`` counts it."""
        words = self.handle_words(function_code, address, count, values)
        return None if words is None else words.tolist()

    def handle_words(self, function_code: int, address: int, count: int,
                     values: list[int] | None = None) -> np.ndarray | None:
        """:meth:`handle` with the words read as a ``uint16`` array."""
        capturing = self._state == self.map.states["capturing"]
        size = len(values) if function_code in _WRITE_FCS and values else count
        try:
            words = self._handle(function_code, address, count, values)
        except Refusal:
            self.traffic.add(*pdu_sizes(function_code, size, True), capturing)
            raise
        self.traffic.add(*pdu_sizes(function_code, size, False), capturing)
        return words

    def _handle(self, function_code: int, address: int, count: int,
                values: list[int] | None) -> np.ndarray | None:
        if self.fail_next_kind == "exception":
            self.fail_next_kind = None
            raise Refusal(EXC_DEVICE_FAILURE, "injected failure")
        if function_code in _BIT_FCS:
            raise Refusal(EXC_ILLEGAL_ADDRESS, "the device has no coils or discrete inputs")
        if function_code not in _REGISTER_FCS:
            raise Refusal(EXC_ILLEGAL_FUNCTION, f"function code {function_code}")
        writing = function_code in _WRITE_FCS
        if writing:
            count = len(values or [])
        limit = 123 if function_code == 16 else 125
        if not 1 <= count <= limit:
            raise Refusal(EXC_ILLEGAL_VALUE, f"count {count}")
        table = "input" if function_code == _INPUT_FC else "holding"
        if not self._image[table].mapped(address, count):
            raise Refusal(EXC_ILLEGAL_ADDRESS, f"{table} {address}..{address + count - 1}")
        if writing:
            self._write_holding(address, list(values))
            return None
        with self._lock:
            if table == "input":
                self._refresh_inputs(address, count)
            else:
                self._set("dyno_speed_setpoint_rpm", self._speed_setpoint_rpm)
            return self._image[table].read(address, count)

    def maps(self, function_code: int, address: int, count: int) -> bool:
        """Every register of a read (function code 3 or 4) is in the map."""
        image = self._image["input" if function_code == _INPUT_FC else "holding"]
        return count <= 125 and image.mapped(address, count)

    def read_file_record(self, file: int, record: int, count: int) -> list[int]:
        """One Read File Record (0x14) sub-request on a ``file_record`` map: the buffer words
        at (file, record) as its ``[transfer]`` lays them out; raises Refusal like the spec
        (function not offered 1, file/record outside 2, length 3) and the device (busy 6,
        past the captured data 2)."""
        capturing = self._state == self.map.states["capturing"]
        try:
            words = self._file_record(file, record, count)
        except Refusal:
            self.traffic.add(2 + 7, 2, capturing)
            raise
        self.traffic.add(2 + 7, 4 + 2 * count, capturing)
        return words

    def _file_record(self, file: int, record: int, count: int) -> list[int]:
        transfer = self.map.transfer
        if transfer.kind != "file_record":
            raise Refusal(EXC_ILLEGAL_FUNCTION, "this DAQ's buffer is not in file records")
        if self.fail_next_kind == "exception":
            self.fail_next_kind = None
            raise Refusal(EXC_DEVICE_FAILURE, "injected failure")
        if not 1 <= count <= transfer.words_per_request:
            raise Refusal(EXC_ILLEGAL_VALUE, f"record length {count}")
        begin = transfer.word_of(file, record)
        if begin < 0 or not 0 <= record <= transfer.records_per_file - count:
            raise Refusal(EXC_ILLEGAL_ADDRESS, f"file {file} record {record}+{count}")
        with self._lock:
            if self._state == self.map.states["capturing"]:
                raise Refusal(EXC_BUSY, "capturing")
            if self._state != self.map.states["done"] or begin + count > len(self._words):
                raise Refusal(EXC_ILLEGAL_ADDRESS, "past the captured data")
            return self._words[begin:begin + count].tolist()

    def _set(self, name: str, value) -> None:
        reg = self.map[name]
        self._image[reg.table].write(reg.address, reg.encode(value))

    def _refresh_inputs(self, address: int, count: int) -> None:
        """The device's state into the input registers a read of ``address``, ``count``
        covers (the others are not looked at before the next read refreshes them)."""
        values = (self._state, self._flags, self._samples_captured, self._words_per_sample)
        for reg, value in zip(self._live_registers, values):
            if reg.table != "input" or (reg.address < address + count
                                        and address < reg.address + reg.words):
                self._image[reg.table].write(reg.address, reg.encode(value))
        for name, value in self._first_values.items():
            self._set(name, value)
        window = self.map.registers.get("buffer_window")
        if window is not None and address + count > window.address \
                and address < window.address + window.words:
            self._fill_window(address, count, window)

    def _fill_window(self, address: int, count: int, window) -> None:
        if self._state == self.map.states["capturing"]:
            raise Refusal(EXC_BUSY, "capturing")
        auto = self._read_mode == self.map.buffer_read_modes.get("auto_increment")
        if auto and address != window.address:
            raise Refusal(EXC_ILLEGAL_ADDRESS, "auto-increment reads start at the window")
        first = max(address, window.address) - window.address
        last = min(address + count, window.address + window.words) - window.address
        begin = self._pointer + first
        end = self._pointer + last
        if self._state != self.map.states["done"] or end > len(self._words):
            raise Refusal(EXC_ILLEGAL_ADDRESS, "past the captured data")
        self._image["input"].write(window.address + first, self._words[begin:end])
        if auto:
            self._pointer = end

    def _write_holding(self, address: int, values: list[int]) -> None:
        image = self._image["holding"].copy()
        image.write(address, values)
        touched = [reg for reg in self.map.registers.values() if reg.table == "holding"
                   and reg.address < address + len(values) and address < reg.address + reg.words]
        with self._lock:
            saved = dict(self._config), self._page, self._pointer, self._read_mode
            try:
                for reg in touched:
                    self._apply(reg.name, reg.decode(image.read(reg.address,
                                                                 reg.words).tolist()))
            except Refusal:
                # a refused write changes no setting
                self._config, self._page, self._pointer, self._read_mode = saved
                raise
            self._image["holding"] = image

    def _apply(self, name: str, value) -> None:
        states = self.map.states
        busy = self._state in (states["armed"], states["capturing"])
        if name == "control":
            self._control(int(value))
        elif name == "dyno_speed_setpoint_rpm":
            reg = self.map[name]
            if not math.isfinite(value) or not reg.minimum <= value <= reg.maximum:
                raise Refusal(EXC_ILLEGAL_VALUE, f"speed {value}")
            self._speed_setpoint_rpm = float(value)
            self._speed_pending = True
            if self.twin.lock.acquire(timeout=SPEED_APPLY_WAIT_S):
                try:
                    self._apply_speed_setpoint()
                finally:
                    self.twin.lock.release()
            # else a capture holds the twin: its worker applies the setpoint when it ends
        elif name in ("buffer_page", "buffer_read_mode"):
            if self._state == states["capturing"]:
                raise Refusal(EXC_BUSY, "capturing")
            if name == "buffer_read_mode":
                if int(value) not in self.map.buffer_read_modes.values():
                    raise Refusal(EXC_ILLEGAL_VALUE, f"buffer_read_mode {value}")
                self._read_mode, self._page = int(value), 0
            else:
                self._page = int(value)
            self._pointer = self._page * self.map.window_words
        else:
            if busy:
                raise Refusal(EXC_BUSY, "armed or capturing")
            if not self._config_value_ok(name, int(value)):
                raise Refusal(EXC_ILLEGAL_VALUE, f"{name} {value}")
            self._config[name] = int(value)

    def _apply_speed_setpoint(self) -> None:
        """Hand a pending speed setpoint to the dyno (call with the twin's lock held)."""
        if self._speed_pending:
            self._speed_pending = False
            try:
                self.twin.speed_rpm = self._speed_setpoint_rpm
            except ValueError:
                raise Refusal(EXC_ILLEGAL_VALUE, "the dyno refused the speed") from None

    def _config_value_ok(self, name: str, value: int) -> bool:
        if name == "sample_rate_hz":
            return 1 <= value <= int(self.device["max_sample_rate_hz"])
        if name == "samples":
            return value >= 1
        if name == "channel_mask":
            return value != 0 and value & ~self.map.all_channels_mask == 0
        if name == "settle_ms":
            return value <= int(self.device["max_settle_ms"])
        if name == "capture_format":
            return value in self.map.capture_formats.values()
        return False

    def _control(self, code: int) -> None:
        codes, states = self.map.control_codes, self.map.states
        if code == codes["disarm"]:
            self._generation += 1
            self._state = states["idle"]
            self._flags = 0
            self._words = np.zeros(0, dtype=np.uint16)
            self._samples_captured = 0
        elif code == codes["arm"]:
            if self._state == states["capturing"]:
                raise Refusal(EXC_BUSY, "capturing")
            self._generation += 1
            self._state = states["armed"]
            self._flags = 0
            self._samples_captured = 0
        elif code == codes["trigger"]:
            if self._state == states["capturing"]:
                raise Refusal(EXC_BUSY, "capturing")
            if self._state != states["armed"]:
                raise Refusal(EXC_ILLEGAL_VALUE, "trigger while not armed")
            self._state = states["capturing"]
            self._worker = threading.Thread(target=self._capture, args=(self._generation,
                                            dict(self._config)), daemon=True,
                                            name="sim-daq-capture")
            self._worker.start()
        else:
            raise Refusal(EXC_ILLEGAL_VALUE, f"control {code}")

    # ------------------------------------------------------------------ capture engine
    def _capture(self, generation: int, config: dict) -> None:
        rate = float(config["sample_rate_hz"])
        capacity = self._constants["buffer_capacity_samples"]
        wanted = config["samples"]
        n = min(wanted, capacity)
        channels = self.map.channels_in(config["channel_mask"])
        packed = self.map.offers_packed and \
            config.get("capture_format") == self.map.capture_formats.get("packed")
        flags = 1 << self.map.status_flags["overrun"] if wanted > capacity else 0
        ticks = stored_ticks(n, drop_every_nth(self.twin))
        counter = self.map.sample_counter
        # the twin computes only what this capture stores (the counter is the DAQ's own clock)
        asked = [channel.name for channel in channels
                 if counter is None or channel.name != counter.name]
        asked = _twin_channels(asked)
        try:
            with self.twin.lock:
                if config["settle_ms"]:
                    self.twin.advance(config["settle_ms"] / 1000.0, rate, channels=())
                if self.pwm_synchronous and hasattr(self.twin, "advance_to_carrier_valley"):
                    self.twin.advance_to_carrier_valley()
                slots = int(ticks[-1]) + 1
                timing = sample_timing(self.twin, ticks)
                extra = 1 if timing.oversample > 1 else 0     # room for a late last sample
                data = self.twin.advance((slots + extra) / (rate * timing.clock),
                                         rate * timing.clock * timing.oversample,
                                         channels=asked)
                with self._lock:
                    try:
                        self._apply_speed_setpoint()    # written while this capture ran
                    except Refusal:
                        log.error("dyno speed setpoint %s rpm refused by the twin",
                                  self._speed_setpoint_rpm)
            data = _daq_view(self.twin, data, asked, self.channel_gains)
            columns, first_values = [], {}
            for channel in channels:
                values = ticks if counter is not None and channel.name == counter.name \
                    else np.asarray(data[channel.name])[timing.index]
                raw, clipped = channel.to_raw(values)
                if clipped:
                    flags |= 1 << self.map.status_flags["clipped"]
                if packed and channel.packed_first_register:
                    first_values[channel.packed_first_register] = int(raw[0])
                columns.append(channel.to_words(raw, packed))
            frames = np.concatenate(columns, axis=1)
            outcome = (self.map.states["done"], frames.reshape(-1), len(frames),
                       frames.shape[1], first_values)
        except Exception:  # noqa: BLE001 - a firmware fault is reported in the state register
            log.exception("simulated DAQ capture failed")
            outcome = (self.map.states["fault"], np.zeros(0, dtype=np.uint16), 0, 0, {})
        with self._lock:
            if generation != self._generation:
                return          # disarmed (or re-armed) meanwhile: discard
            (self._state, self._words, self._samples_captured, self._words_per_sample,
             self._first_values) = outcome
            self._flags = flags
            self._page = self._pointer = 0


#: DAQ channels the twin does not compute itself: name -> the twin channels it is made of.
DERIVED_CHANNELS = {"vab_v": ("va_v", "vb_v")}


def _twin_channels(asked: list[str]) -> list[str]:
    out = []
    for name in asked:
        for twin_name in DERIVED_CHANNELS.get(name, (name,)):
            if twin_name not in out:
                out.append(twin_name)
    return out


def _daq_view(twin, data, asked: list[str], gains: dict | None = None) -> dict:
    """The twin's channels as the DAQ's inputs see them: the differential voltage v_ab, and the
    encoder counter with the test-only ``encoder_commutation_offset_elec_deg`` defect (the
    counter's zero that far, in electrical degrees, ahead of the rotor's electrical zero), each
    channel of ``gains`` read with its gain error."""
    view = {name: data[name] for name in asked if name in data}
    if "va_v" in view and "vb_v" in view:
        view["vab_v"] = np.asarray(data["va_v"]) - np.asarray(data["vb_v"])
    offset_deg = float(getattr(getattr(twin, "defects", None),
                               "encoder_commutation_offset_elec_deg", 0.0) or 0.0)
    if offset_deg and "encoder_counts" in view:
        counts = _twin_setting(twin, "sensors", "encoder_counts_per_rev")
        pole_pairs = _twin_setting(twin, "motor", "parameters", "pole_pairs")
        if counts and pole_pairs:
            shift = int(round(offset_deg / 360.0 / pole_pairs * counts))
            view["encoder_counts"] = np.asarray(data["encoder_counts"]) + shift
    for name, gain in (gains or {}).items():
        if name in view:
            view[name] = np.asarray(view[name]) * gain
    return view


class SampleTiming(NamedTuple):
    """Where the DAQ really samples: the twin runs at ``clock`` × the stated rate ×
    ``oversample``, and stored sample i is the twin's sample ``index[i]``."""

    clock: float
    oversample: int
    index: np.ndarray


#: Steps per sample period in which the jitter defect moves a sample instant.
JITTER_STEPS = 8


def sample_timing(twin, ticks: np.ndarray) -> SampleTiming:
    """The sample instants of a capture whose stored ticks are ``ticks``: the tick itself on a
    healthy DAQ; with the test-only ``daq_clock_scale`` defect the twin is sampled at that × the
    stated rate (the time base stays the stated one); with ``daq_sample_jitter_samples`` = j
    each instant moves by a uniform whole number of 1/8 sample periods within ±j (the tick count
    stays nominal: only the instants are off)."""
    defects = getattr(twin, "defects", None)
    clock = float(getattr(defects, "daq_clock_scale", 1.0) or 1.0)
    jitter = float(getattr(defects, "daq_sample_jitter_samples", 0.0) or 0.0)
    steps = int(math.floor(jitter * JITTER_STEPS + 1e-9))
    if not steps:
        return SampleTiming(clock, 1, np.asarray(ticks))
    rng = np.random.default_rng(len(ticks))
    offsets = rng.integers(-steps, steps + 1, size=len(ticks))
    index = np.clip(np.asarray(ticks) * JITTER_STEPS + offsets, 0, None)
    return SampleTiming(clock, JITTER_STEPS, index)


def drop_every_nth(twin) -> int:
    """The twin's test-only ``daq_drop_every_nth`` defect (0: the DAQ loses no sample)."""
    return int(getattr(getattr(twin, "defects", None), "daq_drop_every_nth", 0) or 0)


def stored_ticks(n: int, every_nth: int = 0) -> np.ndarray:
    """Sample-clock ticks of the ``n`` samples the DAQ stores.

    A healthy DAQ stores ticks 0..n-1. With the ``daq_drop_every_nth`` defect it silently loses
    every n-th tick (the 10th, 20th, ... for n = 10) and keeps sampling until it has stored ``n``
    samples: the count comes out right, the time base does not (only the sample counter shows it).
    """
    ticks = np.arange(n if not every_nth else n + (n - 1) // (every_nth - 1), dtype=np.int64)
    if every_nth:
        ticks = ticks[(ticks + 1) % every_nth != 0][:n]
    return ticks


def _twin_setting(twin, *path: str):
    """``twin.config.<path>`` (e.g. the encoder's counts per revolution), None if absent; the
    DAQ then reports the register map's default."""
    value = getattr(twin, "config", None)
    for name in path:
        value = getattr(value, name, None)
    return value


class SimulatedDaq:
    """A Modbus DAQ server backed by a DriveTwin; TCP by default, ``SimulatedDaq.rtu`` for RTU."""

    def __init__(self, twin, host: str = "127.0.0.1", port: int = 0, *, unit_id: int = 1,
                 register_map=None, serial_number: str = "SIM-DAQ-0001",
                 pwm_synchronous: bool = True, channel_gains: dict | None = None) -> None:
        self.twin = twin
        self.map = register_map if isinstance(register_map, RegisterMap) \
            else load_register_map(register_map)
        self.device = DaqDevice(twin, self.map, serial_number, pwm_synchronous=pwm_synchronous,
                                channel_gains=channel_gains)
        self.unit_id = unit_id
        self._host, self._port = host, port
        self._serial: dict | None = None
        self._bridge: PtyBridge | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._server = None
        self._thread: threading.Thread | None = None
        self._started = threading.Event()
        self._start_error: BaseException | None = None
        self._bound: tuple[str, int] | None = None
        self.line_note = ""

    @classmethod
    def rtu(cls, twin, *, baudrate: int = 115200, parity: str = "E", stopbits: int = 1,
            pace_baud: bool = False, unit_id: int = 1, register_map=None,
            serial_number: str = "SIM-DAQ-0001",
            channel_gains: dict | None = None) -> "SimulatedDaq":
        """An RTU DAQ on a pseudo-terminal (8 data bits, ``parity``, ``stopbits``; default 8E1);
        after ``start()`` the client opens ``sim.port``."""
        if parity not in PARITIES or stopbits not in STOPBITS:
            raise ValueError(f"simulated DAQ line parity={parity!r} stopbits={stopbits!r}; "
                             f"allowed parity {PARITIES}, stopbits {STOPBITS}")
        sim = cls(twin, unit_id=unit_id, register_map=register_map,
                  serial_number=serial_number, channel_gains=channel_gains)
        sim._serial = {"baudrate": baudrate, "parity": parity, "stopbits": stopbits,
                       "pace_baud": pace_baud}
        return sim

    # ------------------------------------------------------------------ lifecycle
    def start(self) -> "SimulatedDaq":
        if self._serial is not None:
            line = self._serial
            self._bridge = PtyBridge(line["baudrate"] if line["pace_baud"] else None,
                                     bits_per_char(line["parity"], line["stopbits"]))
            self._bridge.start()
        self._thread = threading.Thread(target=self._serve, daemon=True, name="sim-daq-modbus")
        self._thread.start()
        if not self._started.wait(10.0) or self._start_error is not None:
            self.stop()
            raise RuntimeError(f"simulated DAQ did not start: {self._start_error}")
        return self

    def stop(self) -> None:
        if self._loop is not None and self._server is not None and self._loop.is_running():
            future = asyncio.run_coroutine_threadsafe(self._server.shutdown(), self._loop)
            try:
                future.result(5.0)
            except Exception:  # noqa: BLE001 - best effort on teardown
                log.debug("simulated DAQ shutdown", exc_info=True)
        if self._thread is not None:
            self._thread.join(5.0)
        if self._bridge is not None:
            self._bridge.stop()
        worker = self.device._worker
        if worker is not None:
            worker.join(30.0)

    def __enter__(self) -> "SimulatedDaq":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()

    @property
    def address(self) -> tuple[str, int]:
        """(host, port) of the TCP server."""
        if self._bound is None:
            raise RuntimeError("simulated DAQ is not a started TCP server")
        return self._bound

    @property
    def port(self) -> str:
        """Device path the RTU client opens."""
        if self._bridge is None:
            raise RuntimeError("simulated DAQ is not a started RTU server")
        return self._bridge.client_port

    def fail_next(self, kind: str = "exception") -> None:
        """Make the next request fail: "exception", "timeout" or "disconnect" (TCP: the
        connection closed after the unanswered request; RTU has no connection to drop: the
        request goes unanswered, as "timeout")."""
        if kind not in FAIL_KINDS:
            raise ValueError(f"fail_next kind={kind!r}; allowed {FAIL_KINDS}")
        self.device.fail_next_kind = kind

    # ------------------------------------------------------------------ server thread
    def _trace_packet(self, sending: bool, data: bytes) -> bytes:
        kind = self.device.fail_next_kind
        if not sending or kind not in ("timeout", "disconnect"):
            return data
        self.device.fail_next_kind = None
        # a closed serial handler is never reopened: on RTU the line stays up (review h-19)
        if kind == "disconnect" and self._server is not None and self._bridge is None:
            self._loop.call_soon(self._close_connections)
        return b""

    def _close_connections(self) -> None:
        for connection in list(self._server.active_connections.values()):
            connection.close()

    def _serve(self) -> None:
        self._loop = asyncio.new_event_loop()
        asyncio.set_event_loop(self._loop)
        try:
            self._loop.run_until_complete(self._main())
        except BaseException as exc:  # noqa: BLE001 - reported to start()
            self._start_error = exc
            self._started.set()
        finally:
            self._loop.close()

    async def _action(self, function_code, start_address, address, count, registers,
                      set_values):
        """pymodbus SimDevice hook: the device answers; its words go into pymodbus's image.
        (pymodbus calls it again without values after a write, to echo it: a holding read.)"""
        if function_code in _WRITE_FCS and not set_values:
            image = self.device._image["holding"]           # the echo: not a request
            registers[address - start_address:address - start_address + count] = \
                image.read(address, count).tolist()
            return None
        try:
            words = self.device.handle(function_code, address, count, set_values or None)
        except Refusal as refusal:
            return ExcCodes(refusal.code)
        if words is not None:
            registers[address - start_address:address - start_address + count] = words
        return None

    def _simdata(self) -> tuple[list[SimData], list[SimData]]:
        """(holding, input) pymodbus blocks covering every mapped register."""
        holding, inputs = [], []
        for reg in self.map.registers.values():
            entry = SimData(reg.address, values=[0] * reg.words, datatype=DataType.REGISTERS)
            (holding if reg.table == "holding" else inputs).append(entry)
        return holding, inputs

    async def _main(self) -> None:
        holding, inputs = self._simdata()
        bits = [SimData(0, values=False, datatype=DataType.BITS)]   # pymodbus needs a block;
        device = SimDevice(self.unit_id, simdata=(bits, list(bits), holding, inputs),
                           action=self._action)                     # the device refuses it
        if self._bridge is not None:
            parity, self.line_note = line_for_port(self._bridge.server_port,
                                                   self._serial["parity"])
            self._server = _InOrderSerialServer(device, port=self._bridge.server_port,
                                              baudrate=self._serial["baudrate"], bytesize=8,
                                              parity=parity, stopbits=self._serial["stopbits"],
                                              trace_packet=self._trace_packet)
        else:
            self._server = _InOrderTcpServer(device, address=(self._host, self._port),
                                             trace_packet=self._trace_packet)
        self._server.daq_device = self.device       # answers register reads and Read File
        self._server.daq_unit_id = self.unit_id     # Record (0x14) itself
        self._server.decoder.register(_FileRecordRequest)
        await self._server.serve_forever(background=True)
        if self._bridge is None:
            self._bound = tuple(self._server.transport.sockets[0].getsockname()[:2])
        self._started.set()
        await self._server.serving


class _InOrderRequestHandler(ServerRequestHandler):
    """A pymodbus connection handler that answers pipelined requests, in order, as the map says.

    Modbus TCP lets a client send requests before the earlier answers arrive. pymodbus 3.16's
    handler decodes one frame per received segment and keeps one ``last_pdu``, so frames that
    arrive together wait for more data or are overwritten. This one decodes every complete frame
    of the buffer into a queue and answers them one after another. pymodbus answers some function
    codes itself (7, 8, 11, 17, 43: its own diagnostics and identity); the DAQ's map lists none of
    them, so they get exception 1, and a malformed quantity of a listed code exception 3.
    """

    def __init__(self, *args) -> None:
        super().__init__(*args)
        self._queue: collections.deque = collections.deque()
        self._draining = False
        # pymodbus drops the whole receive buffer, silently, once it holds more than one ADU
        # (260 bytes): 22 pipelined 12-byte requests arriving together were lost and the client
        # waited for answers that never came. This handler takes every complete frame out of
        # what it receives, so only bytes it cannot frame can pile up (dropped below).
        self.max_buffer_size = sys.maxsize
        # pymodbus's send() also empties the receive buffer, so the first part of a pipelined
        # request that came in behind the one being answered was lost; answers go out here
        self.low_level_send = self._write_answer
        self._gathered: list[bytes] | None = None

    def _write_answer(self, data: bytes, addr: tuple | None = None) -> None:
        """Write one answer ADU; while a batch drains, gather it and write the batch at once
        (one write per batch instead of one per answer)."""
        if self._gathered is not None:
            self._gathered.append(data)
        elif self.transport:
            self.transport.write(data)

    def callback_data(self, data: bytes, addr: tuple | None = None) -> int:
        used = 0
        tcp = isinstance(self.framer, FramerSocket)
        while used < len(data):
            frame = data[used:]
            if tcp:     # one ADU at a time, delimited by its MBAP header (review h-19)
                size = _mbap_size(frame)
                if size is None:
                    break                           # an incomplete frame: wait for more data
                if size == 0:
                    log.warning("simulated DAQ: %d bytes that are not Modbus TCP dropped",
                                len(frame))
                    used = len(data)
                    break
                frame = frame[:size]
                if frame[2:4] != b"\0\0":           # protocol id 0 is Modbus (spec §4.1)
                    log.warning("simulated DAQ: a frame of protocol id %d skipped",
                                int.from_bytes(frame[2:4], "big"))
                    used += size
                    continue
            try:
                cut = TransactionManager.callback_data(self, frame, addr)
            except ModbusIOException as exc:
                # a malformed quantity: its exception answer goes out in its turn, and (TCP)
                # the frames after it are still answered
                decoded = self.framer.decode(frame)[3]
                function_code = decoded[0] if decoded else 0
                code = EXC_ILLEGAL_VALUE if function_code in _REGISTER_FCS else \
                    EXC_ILLEGAL_FUNCTION
                self._queue.append((ExceptionResponse(function_code,
                                                      exception_code=ExcCodes(code),
                                                      device_id=exc.dev_id,
                                                      transaction=exc.transaction_id), addr))
                cut = len(frame)                    # RTU: the rest of the segment with it
            if self.last_pdu is not None:
                self._queue.append((self.last_pdu, addr))
            elif cut == 0 and not tcp:
                break                               # an incomplete frame: wait for more data
            used += len(frame) if tcp else cut
        if self._queue and not self._draining:
            self._draining = True
            self.loop.create_task(self._drain())
        if used == 0 and len(data) > MAX_ADU_BYTES:
            return len(data)    # more than an ADU and no frame in it: not Modbus, dropped
        return used

    async def _drain(self) -> None:
        self._gathered = []
        try:
            while self._queue:
                self.last_pdu, self.last_addr = self._queue.popleft()
                if isinstance(self.last_pdu, ExceptionResponse):    # refused when received
                    self.server_send(self.last_pdu, self.last_addr)
                elif self._is_register_read(self.last_pdu):
                    self.server_send(self._register_read(self.last_pdu), self.last_addr)
                elif self.last_pdu.function_code in _DATASTORE_FCS:
                    await self.handle_request()
                elif self.last_pdu.function_code == ReadFileRecordRequest.function_code:
                    self.server_send(self._file_records(self.last_pdu), self.last_addr)
                else:
                    refusal = ExceptionResponse(self.last_pdu.function_code,
                                                ExcCodes.ILLEGAL_FUNCTION)
                    refusal.transaction_id = self.last_pdu.transaction_id
                    refusal.dev_id = self.last_pdu.dev_id
                    self.server_send(refusal, self.last_addr)
        finally:
            self._draining = False
            answers, self._gathered = b"".join(self._gathered), None
            if answers and self.transport:
                self.transport.write(answers)


    def _is_register_read(self, request) -> bool:
        """A Read Holding/Input Registers request for this unit within the map (anything else
        takes pymodbus's own path, which refuses an unmapped address before the device)."""
        return request.function_code in _READ_FCS and \
            request.dev_id == self.server.daq_unit_id and \
            self.server.daq_device.maps(request.function_code, request.address, request.count)

    def _register_read(self, request):
        """The answer to a Read Holding/Input Registers request, straight from the DAQ device
        (the same words and exceptions pymodbus's datastore would pass on, without copying
        them through its register image: the capture buffer is read this way)."""
        try:
            words = self.server.daq_device.handle_words(request.function_code, request.address,
                                                        request.count)
        except Refusal as refusal:
            answer = ExceptionResponse(request.function_code, ExcCodes(refusal.code))
        except Exception:  # noqa: BLE001 - as pymodbus's handler: the device failed
            log.exception("simulated DAQ: register read failed")
            answer = ExceptionResponse(request.function_code, ExcCodes.DEVICE_FAILURE)
        else:
            answer = _READ_RESPONSES[request.function_code]()
            answer.registers, answer.count = words, len(words)
        answer.transaction_id = request.transaction_id
        answer.dev_id = request.dev_id
        return answer

    def _file_records(self, request: _FileRecordRequest):
        """The answer to a Read File Record request: each sub-request's words from the DAQ
        device (pymodbus's own server answers 0x14 with a placeholder), or its exception."""
        device = self.server.daq_device
        try:
            if not request.sub_requests:
                raise Refusal(EXC_ILLEGAL_VALUE, "byte count outside 0x07..0xF5")
            records = []
            for reference, file, record, length in request.sub_requests:
                if reference != FILE_REFERENCE_TYPE:
                    raise Refusal(EXC_ILLEGAL_ADDRESS, f"reference type {reference}, not 6")
                words = device.read_file_record(file, record, length)
                records.append(FileRecord(record_data=struct.pack(f">{length}H", *words)))
        except Refusal as refusal:
            answer = ExceptionResponse(request.function_code, ExcCodes(refusal.code))
        else:
            answer = ReadFileRecordResponse(records=records)
        answer.transaction_id = request.transaction_id
        answer.dev_id = request.dev_id
        return answer


def _mbap_size(data: bytes) -> int | None:
    """Bytes of the Modbus TCP ADU ``data`` starts with, by its MBAP length field: None while
    ``data`` does not hold it whole, 0 if the field cannot be a request's."""
    if len(data) < 6:
        return None
    size = 6 + int.from_bytes(data[4:6], "big")
    if not 8 <= size <= LONGEST_REQUEST_BYTES:
        return 0
    return size if size <= len(data) else None


#: Read File Record's reference type (spec v1.1b3 §6.14: "must be specified as 6").
FILE_REFERENCE_TYPE = 6


class _FileRecordRequest(ReadFileRecordRequest):
    """Read File Record request decoded as the spec lays it out: ``sub_requests`` holds
    (reference type, file, record, record length in registers) of each 7-byte group, none if
    the byte count is outside 0x07..0xF5 or not whole groups. (pymodbus's own request halves
    the record length and refuses an odd one.)"""

    def decode(self, data: bytes) -> None:
        byte_count = int(data[0]) if data else 0
        whole = 0x07 <= byte_count <= 0xF5 and byte_count % 7 == 0 \
            and len(data) >= 1 + byte_count
        self.sub_requests = [struct.unpack(">BHHH", data[1 + i:8 + i])
                             for i in range(0, byte_count, 7)] if whole else []
        self.records = []


class _InOrderTcpServer(ModbusTcpServer):
    """pymodbus TCP server whose connections answer as ``_InOrderRequestHandler``."""

    def callback_new_connection(self):
        return _InOrderRequestHandler(self, self.trace_packet, self.trace_pdu,
                                      self.trace_connect)


class _InOrderSerialServer(ModbusSerialServer):
    """pymodbus RTU server whose line answers as ``_InOrderRequestHandler``."""

    def callback_new_connection(self):
        return _InOrderRequestHandler(self, self.trace_packet, self.trace_pdu,
                                      self.trace_connect)


class PtyBridge:
    """Two raw pseudo-terminals joined by a thread: the server opens one, the client the other.

    With ``pace_baud`` each chunk is delayed by its time on a real line (``bits_per_char`` bits
    per byte: 11 for 8E1 and 8N2, 10 for 8N1).
    """

    def __init__(self, pace_baud: int | None, bits_per_char: int = 11) -> None:
        self.pace_baud = pace_baud
        self.bits_per_char = bits_per_char
        self._server_master, server_slave = os.openpty()
        self._client_master, client_slave = os.openpty()
        for fd in (server_slave, client_slave, self._server_master, self._client_master):
            tty.setraw(fd)
        self.server_port = os.ttyname(server_slave)
        self.client_port = os.ttyname(client_slave)
        # keep the slave ends open so the masters never see EOF/EIO between client sessions
        self._slaves = (server_slave, client_slave)
        self._stop_r, self._stop_w = os.pipe()
        self._thread = threading.Thread(target=self._run, daemon=True, name="sim-daq-pty")

    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        os.write(self._stop_w, b"x")
        self._thread.join(5.0)
        for fd in (self._server_master, self._client_master, *self._slaves, self._stop_r,
                   self._stop_w):
            try:
                os.close(fd)
            except OSError:
                pass

    def _run(self) -> None:
        peers = {self._server_master: self._client_master,
                 self._client_master: self._server_master}
        while True:
            try:
                ready, _, _ = select.select([*peers, self._stop_r], [], [], 1.0)
            except (OSError, ValueError):
                return                     # descriptors closed under us: stopping
            if self._stop_r in ready:
                return
            for fd in ready:
                try:
                    data = os.read(fd, 4096)
                except OSError:
                    continue
                if self.pace_baud:
                    time.sleep(len(data) * self.bits_per_char / self.pace_baud)
                os.write(peers[fd], data)
