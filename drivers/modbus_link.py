"""pymodbus clients that keep the reason a link to the DAQ could not be made.

pymodbus 3.x only *logs* why it could not connect ("[Errno 111] Connection refused") and
returns False; the caller sees a settings repr or "Client cannot connect". These subclasses keep
the reason in ``connect_error`` so the DAQ driver puts it in its typed error (issue 11, design
§6). Everything else is pymodbus's own client.
"""

from __future__ import annotations

import os
import socket

from pymodbus.client import ModbusSerialClient, ModbusTcpClient

from drivers.errors import transport_reason


class TcpClient(ModbusTcpClient):
    """``ModbusTcpClient`` whose failed ``connect`` leaves the OS reason in ``connect_error``."""

    connect_error: str | None = None

    def connect(self) -> bool:
        if self.socket is None:
            params = self.comm_params
            try:
                self.socket = socket.create_connection(
                    (params.host, params.port), timeout=params.timeout_connect,
                    source_address=params.source_address)
            except OSError as exc:
                self.connect_error = transport_reason(exc)
                return False
            self.connect_error = None
        return super().connect()


class SerialClient(ModbusSerialClient):
    """``ModbusSerialClient`` whose failed ``connect`` leaves the reason in ``connect_error``."""

    connect_error: str | None = None

    def connect(self) -> bool:
        if super().connect():
            self.connect_error = None
            return True
        self.connect_error = serial_open_reason(self.comm_params.host)
        return False


def serial_open_reason(port: str) -> str:
    """Why ``port`` cannot be opened: the OS error of opening it ("[Errno 2] No such file or
    directory: '/dev/ttyUSB9'"), or, if it opens, that the line settings or the lock failed."""
    try:
        fd = os.open(port, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
    except OSError as exc:
        return transport_reason(exc)
    os.close(fd)
    return (f"{port} opens, but not with the line settings asked for, or another process holds "
            f"its exclusive lock")
