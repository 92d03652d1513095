"""Driver of the bench DAQ over Modbus TCP or RTU (pymodbus client).

The DAQ captures the phase currents, the encoder counter, the transducer's analog torque and the
dc-bus voltage synchronously, and drives the dyno's speed reference from an analog output. Its
registers are described by a data file (``drivers/data/daq_registers.toml``, see
``drivers.daq_register_map``). A capture: configure (sample rate, samples, channel mask, settle
time) -> arm -> trigger -> poll the state until "done" -> page the buffer out in 125-register
windows -> convert to engineering units -> disarm. The result is a ``hil.capture.Capture`` with
``time_s`` (from the trigger), ``ia_a``, ``ib_a``, ``encoder_counts`` (the 32-bit counter
unwrapped), ``rotor_angle_mech_rad`` (= counts * 2*pi / counts_per_rev), ``torque_nm`` and
``dc_bus_v``; ``meta["daq_lsb"]`` gives each channel's LSB in SI units for the uncertainty
budget (int16 channels: the map's scale; the angle: 2*pi / counts_per_rev).

Modbus exception codes become typed errors (all ``DeviceFault``): ``IllegalFunction`` (1),
``IllegalAddress`` (2), ``IllegalValue`` (3), ``DeviceFailure`` (4), ``DeviceBusy`` (6); no answer
is ``InstrumentTimeout``; a broken connection is ``InstrumentError``. Each message says which
instrument and what the driver was doing.
"""

from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass

import numpy as np
from pymodbus import FramerType, ModbusException
from pymodbus.client import ModbusSerialClient, ModbusTcpClient
from pymodbus.exceptions import ConnectionException, ModbusIOException

from drivers.daq_register_map import RegisterMap, load_register_map
from drivers.errors import (DeviceFault, InstrumentError, InstrumentTimeout, LimitError,
                            ProtocolError)
from hil.capture import Capture
from hil.errors import InputError


@dataclass(frozen=True)
class ModbusTcpSettings:
    """Modbus TCP endpoint of the DAQ."""

    host: str = "127.0.0.1"
    port: int = 502


@dataclass(frozen=True)
class ModbusRtuSettings:
    """Modbus RTU serial line of the DAQ (8 data bits)."""

    port: str
    baudrate: int = 115200
    parity: str = "N"
    stopbits: int = 1


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
                 instrument_name: str = "daq") -> None:
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
        self._lock = threading.RLock()
        self._identity: dict | None = None
        if isinstance(settings, ModbusTcpSettings):
            self._client = ModbusTcpClient(settings.host, port=settings.port, timeout=timeout_s,
                                           retries=0, reconnect_delay=0.0)
        elif isinstance(settings, ModbusRtuSettings):
            self._client = ModbusSerialClient(settings.port, framer=FramerType.RTU,
                                              baudrate=settings.baudrate, bytesize=8,
                                              parity=settings.parity,
                                              stopbits=settings.stopbits, timeout=timeout_s,
                                              retries=0, reconnect_delay=0.0)
        else:
            raise InputError(f"daq settings must be ModbusTcpSettings or ModbusRtuSettings, "
                             f"got {type(settings).__name__}")

    # ------------------------------------------------------------------ connection
    def connect(self) -> "ModbusDaq":
        with self._lock:
            if not self._client.connect():
                raise InstrumentError(self.name, "connect", f"cannot open {self.settings}")
        return self

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
            try:
                response = request(*args, device_id=self.unit_id, **kwargs)
            except ConnectionException as exc:
                raise InstrumentError(self.name, action, f"connection lost: {exc}") from None
            except ModbusIOException as exc:
                raise InstrumentTimeout(self.name, action,
                                        f"no answer within {self.timeout_s} s ({exc})") from None
            except ModbusException as exc:
                raise InstrumentError(self.name, action, str(exc)) from None
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
            channels=None) -> None:
        """Configure a capture (integer Hz, sample count, channels, settle time) and arm it."""
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
        self.write_registers(sample_rate_hz=rate, samples=int(samples),
                             channel_mask=self.map.mask_of(names), settle_ms=settle_ms)
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

    def read_buffer(self) -> Capture:
        """Page the captured buffer out and convert it to engineering units."""
        status = self.status()
        if status["state"] != "done":
            raise DeviceFault(self.name, "read capture buffer",
                              f"DAQ state is {status['state']!r}, no finished capture")
        config = self.read_registers("sample_rate_hz", "samples", "channel_mask", "settle_ms")
        channels = self.map.channels_in(config["channel_mask"])
        n, words_per_sample = status["samples_captured"], status["words_per_sample"]
        if words_per_sample != sum(c.words for c in channels):
            raise DeviceFault(self.name, "read capture buffer",
                              f"device frame has {words_per_sample} words, map says "
                              f"{sum(c.words for c in channels)} for mask "
                              f"{config['channel_mask']:#x}")
        words = self._read_words(n * words_per_sample)
        frames = words.reshape(n, words_per_sample)
        return self._to_capture(frames, channels, float(config["sample_rate_hz"]),
                                config["settle_ms"] / 1000.0, status["clipped"])

    def _read_words(self, total: int) -> np.ndarray:
        window = self.map["buffer_window"]
        out = np.empty(total, dtype=np.uint16)
        for page, begin in enumerate(range(0, total, window.words)):
            count = min(window.words, total - begin)
            self.write_registers(buffer_page=page)
            response = self._call(f"read capture buffer page {page}",
                                  self._client.read_input_registers, window.address, count=count)
            out[begin:begin + count] = response.registers
        return out

    def _to_capture(self, frames, channels, rate, settle_s, clipped) -> Capture:
        constants = self._device_constants()
        counts_per_rev = int(constants["encoder_counts_per_rev"])
        n = len(frames)
        data = {"time_s": np.arange(n) / rate}
        lsb = {}
        column = 0
        for channel in channels:
            raw = channel.from_words(frames[:, column:column + channel.words])
            column += channel.words
            if channel.is_counter:
                counts = unwrap_counter(raw)
                data["encoder_counts"] = counts
                data["rotor_angle_mech_rad"] = counts * (2.0 * math.pi / counts_per_rev)
                lsb["encoder_counts"] = 1.0
                lsb["rotor_angle_mech_rad"] = 2.0 * math.pi / counts_per_rev
            else:
                data[channel.name] = raw * channel.scale + channel.offset
                lsb[channel.name] = channel.scale
        meta = {"source": "daq", "instrument": self.name, "sample_rate_hz": rate,
                "encoder_counts_per_rev": counts_per_rev,
                "pole_pairs": int(constants["pole_pairs"]), "daq_lsb": lsb,
                "daq_model": constants["model"], "daq_serial_number": constants["serial_number"],
                "daq_settle_s": settle_s, "daq_clipped": bool(clipped)}
        return Capture(channels=data, meta=meta)

    # ------------------------------------------------------------------ capture, high level
    def capture(self, duration_s: float, sample_rate_hz: float, settle_s: float = 0.05,
                timeout_s: float | None = None, channels=None) -> Capture:
        """Configure, arm, trigger, wait, read and disarm; returns the capture in SI units.

        Raises LimitError if a channel clipped (the capture would understate the ripple).
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
        try:
            self.arm(sample_rate_hz, samples, settle_s, channels)
            self.trigger()
            self.wait_done(timeout_s)
            result = self.read_buffer()
        finally:
            self._disarm_quietly()
        if result.meta["daq_clipped"]:
            raise LimitError(self.name, "capture", "a channel hit the end of its int16 range "
                                                   f"(LSBs {result.meta['daq_lsb']})")
        return result

    def _disarm_quietly(self) -> None:
        try:
            self.disarm()
        except InstrumentError:
            pass    # the original error (if any) matters more; the guard disarms again


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
