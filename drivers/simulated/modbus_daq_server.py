"""Simulated Modbus DAQ (TCP or RTU over a pseudo-terminal), backed by a ``hil.sim.DriveTwin``.

A pymodbus server holds the registers of ``drivers/data/daq_registers.toml``; an ``action`` hook
(pymodbus ``SimDevice``) gives them behaviour: status registers are refreshed on read, the
capture buffer window is filled from the page selected in ``buffer_page``, configuration writes
are validated (exception 3, illegal data value) and refused while a capture runs (exception 6,
device busy); unmapped addresses answer exception 2 (illegal data address).

A capture runs in simulated time in a worker thread: under the twin's lock it calls
``twin.advance(settle_s, rate)`` (discarded) then ``twin.advance(n / rate, rate)`` and stores the
scaled int16 / uint32 words of the enabled channels. Asking for more samples than
``buffer_capacity_samples`` stores a full buffer and raises the overrun flag. The holding
register pair ``dyno_speed_setpoint_rpm`` is the DAQ's analog output to the dyno: writing it sets
``twin.speed_rpm`` (if a capture is running, the dyno takes the new speed when that capture's
simulation window ends: the twin changes operating point only between ``advance`` calls).

RTU: ``SimulatedDaq.rtu(twin)`` opens two pseudo-terminals in raw mode; the pymodbus serial server
listens on one, a bridge thread copies bytes between the two master ends (pacing them to the baud
rate when ``pace_baud`` is set, since a pty ignores it), and the client opens ``sim.port``.

``fail_next(kind)`` makes the next request fail: "exception" (answer exception 4, server device
failure), "timeout" (no answer), "disconnect" (no answer and the TCP connection is closed; on RTU a
serial line cannot disconnect, so it behaves as "timeout").
"""

from __future__ import annotations

import asyncio
import logging
import math
import os
import select
import threading
import time
import tty

import numpy as np
from pymodbus.constants import ExcCodes
from pymodbus.server import ModbusSerialServer, ModbusTcpServer
from pymodbus.simulator import DataType, SimData, SimDevice

from drivers.daq_register_map import RegisterMap, load_register_map

log = logging.getLogger(__name__)

FAIL_KINDS = ("exception", "timeout", "disconnect")
#: How long a speed-setpoint write waits for the twin (a transducer reading holds it briefly).
SPEED_APPLY_WAIT_S = 0.05
_INPUT_FC = 4
_HOLDING_FCS = (3, 6, 16, 22, 23)


class _Refusal(Exception):
    """A request the device refuses with a Modbus exception code."""

    def __init__(self, code: ExcCodes) -> None:
        super().__init__(code.name)
        self.code = code


class DaqDevice:
    """The DAQ's register behaviour and capture engine (transport independent)."""

    def __init__(self, twin, register_map: RegisterMap, serial_number: str) -> None:
        self.twin = twin
        self.map = register_map
        self.device = register_map.device
        self._lock = threading.Lock()
        self._state = register_map.states["idle"]
        self._flags = 0
        self._config = {"sample_rate_hz": 10000, "samples": 1000,
                        "channel_mask": register_map.all_channels_mask, "settle_ms": 50}
        self._page = 0
        self._words = np.zeros(0, dtype=np.uint16)
        self._samples_captured = 0
        self._words_per_sample = 0
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
        self.fail_next_kind: str | None = None

    # ------------------------------------------------------------------ register image
    def initial_blocks(self) -> tuple[list[SimData], list[SimData]]:
        """(holding, input) SimData lists covering every mapped register."""
        holding, inputs = [], []
        values = dict(self._constants, **self._config, control=0, buffer_page=0,
                      dyno_speed_setpoint_rpm=self._speed_setpoint_rpm)
        for reg in self.map.registers.values():
            words = reg.encode(values[reg.name]) if reg.name in values else [0] * reg.words
            entry = SimData(reg.address, values=words, datatype=DataType.REGISTERS)
            (holding if reg.table == "holding" else inputs).append(entry)
        return holding, inputs

    async def action(self, function_code, start_address, address, count, registers,
                     set_values):
        """pymodbus SimDevice hook: refresh reads, apply writes; return an ExcCodes to refuse."""
        if self.fail_next_kind == "exception":
            self.fail_next_kind = None
            return ExcCodes.DEVICE_FAILURE
        try:
            if function_code == _INPUT_FC:
                self._refresh_inputs(start_address, address, count, registers)
            elif function_code in _HOLDING_FCS and set_values:
                self._write_holding(start_address, address, list(set_values), registers)
            elif function_code in _HOLDING_FCS:
                self._refresh_holding(start_address, registers)
        except _Refusal as refusal:
            return refusal.code
        return None

    def _put(self, start_address, registers, name, value) -> None:
        reg = self.map[name]
        offset = reg.address - start_address
        registers[offset:offset + reg.words] = reg.encode(value)

    def _refresh_holding(self, start_address, registers) -> None:
        with self._lock:
            self._put(start_address, registers, "dyno_speed_setpoint_rpm",
                      self._speed_setpoint_rpm)

    def _refresh_inputs(self, start_address, address, count, registers) -> None:
        with self._lock:
            for name, value in (("state", self._state), ("status_flags", self._flags),
                                ("samples_captured", self._samples_captured),
                                ("words_per_sample", self._words_per_sample)):
                self._put(start_address, registers, name, value)
            window = self.map["buffer_window"]
            if address + count > window.address and address < window.address + window.words:
                self._fill_window(start_address, address, count, registers, window)

    def _fill_window(self, start_address, address, count, registers, window) -> None:
        if self._state == self.map.states["capturing"]:
            raise _Refusal(ExcCodes.DEVICE_BUSY)
        first = max(address, window.address) - window.address
        last = min(address + count, window.address + window.words) - window.address
        begin = self._page * window.words + first
        end = self._page * window.words + last
        if self._state != self.map.states["done"] or end > len(self._words):
            raise _Refusal(ExcCodes.ILLEGAL_ADDRESS)
        offset = window.address + first - start_address
        registers[offset:offset + last - first] = self._words[begin:end].tolist()

    def _write_holding(self, start_address, address, values, registers) -> None:
        image = list(registers)
        image[address - start_address:address - start_address + len(values)] = values
        touched = [reg for reg in self.map.registers.values() if reg.table == "holding"
                   and reg.address < address + len(values) and address < reg.address + reg.words]
        with self._lock:
            saved = dict(self._config), self._page
            try:
                for reg in touched:
                    offset = reg.address - start_address
                    self._apply(reg.name, reg.decode(image[offset:offset + reg.words]))
            except _Refusal:
                self._config, self._page = saved    # a refused write changes no setting
                raise

    def _apply(self, name: str, value) -> None:
        states = self.map.states
        busy = self._state in (states["armed"], states["capturing"])
        if name == "control":
            self._control(int(value))
        elif name == "dyno_speed_setpoint_rpm":
            reg = self.map[name]
            if not math.isfinite(value) or not reg.minimum <= value <= reg.maximum:
                raise _Refusal(ExcCodes.ILLEGAL_VALUE)
            self._speed_setpoint_rpm = float(value)
            self._speed_pending = True
            if self.twin.lock.acquire(timeout=SPEED_APPLY_WAIT_S):
                try:
                    self._apply_speed_setpoint()
                finally:
                    self.twin.lock.release()
            # else a capture holds the twin: its worker applies the setpoint when it ends
        elif name == "buffer_page":
            if self._state == states["capturing"]:
                raise _Refusal(ExcCodes.DEVICE_BUSY)
            self._page = int(value)
        else:
            if busy:
                raise _Refusal(ExcCodes.DEVICE_BUSY)
            if not self._config_value_ok(name, int(value)):
                raise _Refusal(ExcCodes.ILLEGAL_VALUE)
            self._config[name] = int(value)

    def _apply_speed_setpoint(self) -> None:
        """Hand a pending speed setpoint to the dyno (call with the twin's lock held)."""
        if self._speed_pending:
            self._speed_pending = False
            try:
                self.twin.speed_rpm = self._speed_setpoint_rpm
            except ValueError:
                raise _Refusal(ExcCodes.ILLEGAL_VALUE) from None

    def _config_value_ok(self, name: str, value: int) -> bool:
        if name == "sample_rate_hz":
            return 1 <= value <= int(self.device["max_sample_rate_hz"])
        if name == "samples":
            return value >= 1
        if name == "channel_mask":
            return value != 0 and value & ~self.map.all_channels_mask == 0
        if name == "settle_ms":
            return value <= int(self.device["max_settle_ms"])
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
                raise _Refusal(ExcCodes.DEVICE_BUSY)
            self._generation += 1
            self._state = states["armed"]
            self._flags = 0
            self._samples_captured = 0
        elif code == codes["trigger"]:
            if self._state == states["capturing"]:
                raise _Refusal(ExcCodes.DEVICE_BUSY)
            if self._state != states["armed"]:
                raise _Refusal(ExcCodes.ILLEGAL_VALUE)
            self._state = states["capturing"]
            self._worker = threading.Thread(target=self._capture, args=(self._generation,
                                            dict(self._config)), daemon=True,
                                            name="sim-daq-capture")
            self._worker.start()
        else:
            raise _Refusal(ExcCodes.ILLEGAL_VALUE)

    # ------------------------------------------------------------------ capture engine
    def _capture(self, generation: int, config: dict) -> None:
        rate = float(config["sample_rate_hz"])
        capacity = self._constants["buffer_capacity_samples"]
        wanted = config["samples"]
        n = min(wanted, capacity)
        channels = self.map.channels_in(config["channel_mask"])
        flags = 1 << self.map.status_flags["overrun"] if wanted > capacity else 0
        try:
            with self.twin.lock:
                if config["settle_ms"]:
                    self.twin.advance(config["settle_ms"] / 1000.0, rate)
                data = self.twin.advance(n / rate, rate)
                with self._lock:
                    try:
                        self._apply_speed_setpoint()    # written while this capture ran
                    except _Refusal:
                        log.error("dyno speed setpoint %s rpm refused by the twin",
                                  self._speed_setpoint_rpm)
            columns = []
            for channel in channels:
                raw, clipped = channel.to_raw(np.asarray(data[channel.name])[:n])
                if clipped:
                    flags |= 1 << self.map.status_flags["clipped"]
                columns.append(channel.to_words(raw))
            frames = np.concatenate(columns, axis=1)
            outcome = (self.map.states["done"], frames.reshape(-1), len(frames),
                       frames.shape[1])
        except Exception:  # noqa: BLE001 - a firmware fault is reported in the state register
            log.exception("simulated DAQ capture failed")
            outcome = (self.map.states["fault"], np.zeros(0, dtype=np.uint16), 0, 0)
        with self._lock:
            if generation != self._generation:
                return          # disarmed (or re-armed) meanwhile: discard
            self._state, self._words, self._samples_captured, self._words_per_sample = outcome
            self._flags = flags
            self._page = 0


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
                 register_map=None, serial_number: str = "SIM-DAQ-0001") -> None:
        self.twin = twin
        self.map = register_map if isinstance(register_map, RegisterMap) \
            else load_register_map(register_map)
        self.device = DaqDevice(twin, self.map, serial_number)
        self.unit_id = unit_id
        self._host, self._port = host, port
        self._serial: dict | None = None
        self._bridge: _PtyBridge | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._server = None
        self._thread: threading.Thread | None = None
        self._started = threading.Event()
        self._start_error: BaseException | None = None
        self._bound: tuple[str, int] | None = None

    @classmethod
    def rtu(cls, twin, *, baudrate: int = 115200, pace_baud: bool = False, unit_id: int = 1,
            register_map=None, serial_number: str = "SIM-DAQ-0001") -> "SimulatedDaq":
        """An RTU DAQ on a pseudo-terminal; after ``start()`` the client opens ``sim.port``."""
        sim = cls(twin, unit_id=unit_id, register_map=register_map,
                  serial_number=serial_number)
        sim._serial = {"baudrate": baudrate, "pace_baud": pace_baud}
        return sim

    # ------------------------------------------------------------------ lifecycle
    def start(self) -> "SimulatedDaq":
        if self._serial is not None:
            self._bridge = _PtyBridge(self._serial["baudrate"] if self._serial["pace_baud"]
                                      else None)
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
        """Make the next request fail: "exception", "timeout" or "disconnect"."""
        if kind not in FAIL_KINDS:
            raise ValueError(f"fail_next kind={kind!r}; allowed {FAIL_KINDS}")
        self.device.fail_next_kind = kind

    # ------------------------------------------------------------------ server thread
    def _trace_packet(self, sending: bool, data: bytes) -> bytes:
        kind = self.device.fail_next_kind
        if not sending or kind not in ("timeout", "disconnect"):
            return data
        self.device.fail_next_kind = None
        if kind == "disconnect" and self._server is not None:
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

    async def _main(self) -> None:
        holding, inputs = self.device.initial_blocks()
        bits = [SimData(0, values=False, datatype=DataType.BITS)]
        device = SimDevice(self.unit_id, simdata=(bits, list(bits), holding, inputs),
                           action=self.device.action)
        if self._bridge is not None:
            self._server = ModbusSerialServer(device, port=self._bridge.server_port,
                                              baudrate=self._serial["baudrate"],
                                              trace_packet=self._trace_packet)
        else:
            self._server = ModbusTcpServer(device, address=(self._host, self._port),
                                           trace_packet=self._trace_packet)
        await self._server.serve_forever(background=True)
        if self._bridge is None:
            self._bound = tuple(self._server.transport.sockets[0].getsockname()[:2])
        self._started.set()
        await self._server.serving


class _PtyBridge:
    """Two raw pseudo-terminals joined by a thread: the server opens one, the client the other.

    With ``pace_baud`` each chunk is delayed by its time on a real line (10 bits per byte).
    """

    def __init__(self, pace_baud: int | None) -> None:
        self.pace_baud = pace_baud
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
                    time.sleep(len(data) * 10.0 / self.pace_baud)
                os.write(peers[fd], data)
