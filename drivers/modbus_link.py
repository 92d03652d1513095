"""pymodbus clients that keep the reason a link to the DAQ could not be made.

pymodbus 3.x only *logs* why it could not connect ("[Errno 111] Connection refused") and
returns False; the caller sees a settings repr or "Client cannot connect". These subclasses keep
the error in ``connect_error`` (``None`` after a successful connect) so the DAQ driver puts its
reason in its typed error and raises from it (issue 11, design §6). Everything else is
pymodbus's own client.
"""

from __future__ import annotations

import os
import socket

from pymodbus.client import ModbusSerialClient, ModbusTcpClient

from ripple_hil_drivers.errors import transport_reason


class TcpClient(ModbusTcpClient):
    """``ModbusTcpClient`` whose failed ``connect`` leaves the OS error in ``connect_error``."""

    connect_error: OSError | None = None

    def connect(self) -> bool:
        if self.socket is None:
            params = self.comm_params
            try:
                self.socket = socket.create_connection(
                    (params.host, params.port), timeout=params.timeout_connect,
                    source_address=params.source_address)
            except OSError as exc:
                self.connect_error = exc
                return False
            self.connect_error = None
        return super().connect()


class SerialClient(ModbusSerialClient):
    """``ModbusSerialClient`` whose failed ``connect`` leaves an error saying why in
    ``connect_error`` (pymodbus keeps none: the port is opened again to ask the OS)."""

    connect_error: OSError | None = None

    def connect(self) -> bool:
        if super().connect():
            self.connect_error = None
            return True
        self.connect_error = serial_open_error(self.comm_params.host)
        return False


def serial_open_error(port: str) -> OSError:
    """Why ``port`` cannot be opened: the OS error of opening it ("[Errno 2] No such file or
    directory: '/dev/ttyUSB9'"), or, if it opens, an error saying that the line settings or the
    exclusive lock failed."""
    try:
        fd = os.open(port, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
    except OSError as exc:
        return exc
    os.close(fd)
    return OSError(f"{port} opens, but not with the line settings asked for, or another process "
                   f"holds its exclusive lock")


def connect_reason(client) -> str:
    """The reason of ``client``'s last failed connect ("?" if it kept none)."""
    error = getattr(client, "connect_error", None)
    return transport_reason(error) if error is not None else "?"
