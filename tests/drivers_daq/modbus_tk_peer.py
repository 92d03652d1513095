"""The simulated DAQ served by modbus-tk, a Modbus implementation independent of pymodbus.

modbus-tk does the framing (MBAP over TCP, RTU with CRC and t3.5 timing over a pty), decodes
every request, checks its quantities and block addresses and builds every answer; the DAQ's
behaviour (``ripple_hil_drivers.simulated.modbus_daq_server.DaqDevice``, backed by the twin) is reached
through modbus-tk's per-function hooks, which run before modbus-tk serves a request from its own
register blocks: a read hook copies the device's words into the block, a write hook hands the
decoded values to the device, and a refusal becomes modbus-tk's ``ModbusError`` (its exception
answer).
"""

from __future__ import annotations

import contextlib
import struct
import socket
import time

import serial
from modbus_tk import defines, hooks, modbus_rtu, modbus_tcp
from modbus_tk.exceptions import ModbusError

from ripple_hil_drivers.serial_line import line_for_port
from ripple_hil_drivers.simulated.modbus_daq_server import DaqDevice, PtyBridge, Refusal

_DEVICES: dict[int, DaqDevice] = {}         # id(modbus-tk slave) -> device
_BLOCK_TYPES = {"input": defines.ANALOG_INPUTS, "holding": defines.HOLDING_REGISTERS}
_HOOKS = {3: "handle_read_holding_registers_request", 4: "handle_read_input_registers_request",
          6: "handle_write_single_register_request", 16: "handle_write_multiple_registers_request",
          22: "handle_mask_write_register_request",
          23: "handle_read_write_multiple_registers_request"}


def _request(function_code: int, pdu: bytes) -> tuple[int, int, list[int] | None]:
    """(address, count, values written) of a request PDU."""
    if function_code in (3, 4):
        address, count = struct.unpack(">HH", pdu[1:5])
        return address, count, None
    if function_code == 6:
        address, value = struct.unpack(">HH", pdu[1:5])
        return address, 1, [value]
    if function_code == 16:
        address, count = struct.unpack(">HH", pdu[1:5])
        return address, count, list(struct.unpack(f">{count}H", pdu[6:6 + 2 * count]))
    return 0, 0, None


def _hook(function_code: int):
    def hook(args) -> None:
        slave, pdu = args
        device = _DEVICES.get(id(slave))
        if device is None:
            return
        address, count, values = _request(function_code, pdu)
        try:
            words = device.handle(function_code, address, count, values)
        except Refusal as refusal:
            raise ModbusError(refusal.code) from None
        if words is not None:
            table = "input" if function_code == 4 else "holding"
            slave.set_values(_block_name(device, table, address), address, words)
    return hook


def _runs(device: DaqDevice, table: str) -> list[tuple[int, int]]:
    """Contiguous (start, size) runs of the map's registers in ``table``."""
    spans = sorted((r.address, r.address + r.words) for r in device.map.registers.values()
                   if r.table == table)
    runs: list[list[int]] = []
    for start, end in spans:
        if runs and runs[-1][1] == start:
            runs[-1][1] = end
        else:
            runs.append([start, end])
    return [(start, end - start) for start, end in runs]


def _block_name(device: DaqDevice, table: str, address: int) -> str:
    for start, size in _runs(device, table):
        if start <= address < start + size:
            return f"{table}-{start}"
    raise ModbusError(defines.ILLEGAL_DATA_ADDRESS)


@contextlib.contextmanager
def _hooks_installed():
    installed = [(f"modbus.Slave.{name}", _hook(code)) for code, name in _HOOKS.items()]
    for name, hook in installed:
        hooks.install_hook(name, hook)
    try:
        yield
    finally:
        for name, hook in installed:
            hooks.uninstall_hook(name, hook)


@contextlib.contextmanager
def _serving(server, device: DaqDevice, unit_id: int):
    slave = server.add_slave(unit_id)
    for table, block_type in _BLOCK_TYPES.items():
        for start, size in _runs(device, table):
            slave.add_block(f"{table}-{start}", block_type, start, size)
    _DEVICES[id(slave)] = device
    try:
        with _hooks_installed():
            server.start()
            try:
                yield server
            finally:
                server.stop()
    finally:
        _DEVICES.pop(id(slave), None)
        if device._worker is not None:
            device._worker.join(30.0)


@contextlib.contextmanager
def modbus_tk_tcp(device: DaqDevice, unit_id: int = 1):
    """Serve ``device`` with modbus-tk's TCP server on 127.0.0.1; yields (host, port)."""
    server = modbus_tcp.TcpServer(port=0, address="127.0.0.1")
    with _serving(server, device, unit_id):
        deadline = time.monotonic() + 5.0
        # created, then bound, in the server's thread: a socket not yet bound reads 0.0.0.0:0
        while getattr(server, "_sock", None) is None or server._sock.getsockname()[1] == 0:
            if time.monotonic() > deadline:
                raise RuntimeError("modbus-tk TCP server did not start")
            time.sleep(0.01)
        address = server._sock.getsockname()[:2]
        # bound is not yet listening (a loaded CI host refused the driver's connect in between):
        # wait until a connection is accepted
        while True:
            try:
                socket.create_connection(address, timeout=1.0).close()
                break
            except ConnectionRefusedError:
                if time.monotonic() > deadline:
                    raise RuntimeError("modbus-tk TCP server did not listen") from None
                time.sleep(0.01)
        yield address


@contextlib.contextmanager
def modbus_tk_rtu(device: DaqDevice, *, baudrate: int = 115200, parity: str = "E",
                  stopbits: int = 1, unit_id: int = 1):
    """Serve ``device`` with modbus-tk's RTU server on a pty; yields the client's port path."""
    bridge = PtyBridge(None)
    bridge.start()
    try:
        line = serial.Serial(bridge.server_port, baudrate=baudrate, bytesize=8,
                             parity=line_for_port(bridge.server_port, parity)[0],
                             stopbits=stopbits)
        server = modbus_rtu.RtuServer(line)
        with _serving(server, device, unit_id):
            yield bridge.client_port
    finally:
        bridge.stop()
