"""The simulated DAQ's TCP handler on pipelined requests it must refuse or cannot frame, and a
register map that puts the live status registers in the holding table (review h-18)."""

from __future__ import annotations

import socket
import struct
import time
from pathlib import Path

import pytest

from daq_twin import make_twin
from ripple_hil_drivers.daq_register_map import DEFAULT_MAP_PATH, load_register_map
from hil.errors import InputError
from ripple_hil_drivers.simulated.modbus_daq_server import DaqDevice

pytestmark = [pytest.mark.integration, pytest.mark.timeout(60)]

MAP = load_register_map()
READ_STATE = struct.pack(">BHH", 4, MAP["state"].address, 1)
READ_126 = struct.pack(">BHH", 4, MAP["state"].address, 126)


def adu(tid: int, pdu: bytes) -> bytes:
    return struct.pack(">HHHB", tid, 0, len(pdu) + 1, 1) + pdu


def answers(sock: socket.socket, expected: int, wait_s: float = 2.0) -> list[tuple[int, str]]:
    """(transaction id, function code + first data byte in hex) of each answer, in order."""
    buffer, out = b"", []
    deadline = time.monotonic() + wait_s
    sock.settimeout(0.1)
    while len(out) < expected and time.monotonic() < deadline:
        try:
            buffer += sock.recv(65536)
        except socket.timeout:
            continue
        while len(buffer) >= 6 and len(buffer) >= 6 + struct.unpack(">H", buffer[4:6])[0]:
            n = 6 + struct.unpack(">H", buffer[4:6])[0]
            out.append((struct.unpack(">H", buffer[:2])[0], buffer[7:9].hex()))
            buffer = buffer[n:]
    return out


def test_a_bad_quantity_in_a_batch_is_refused_in_its_turn_and_the_rest_answered(daq_server):
    """Was: only the exception answer came back, first; requests 1, 3 and 4 never did."""
    batch = adu(1, READ_STATE) + adu(2, READ_126) + adu(3, READ_STATE) + adu(4, READ_STATE)
    with socket.create_connection(daq_server.address) as sock:
        sock.sendall(batch)
        got = answers(sock, 4)
    assert [tid for tid, _ in got] == [1, 2, 3, 4]
    assert got[1][1] == "8403"                      # exception 3: quantity 126 > 125
    assert all(code.startswith("0402") for _, code in got[:1] + got[2:])


def test_live_status_registers_in_the_holding_table_stay_live(tmp_path):
    """A map may put ``state`` in the holding table: an input read must not write it over an
    input register at the same address, and the holding register must follow the device."""
    text = Path(DEFAULT_MAP_PATH).read_text()
    state = MAP["state"]
    moved = text.replace(f'[registers.state]\ntable = "input"\naddress = {state.address}',
                         '[registers.state]\ntable = "holding"\naddress = 20')
    assert moved != text
    path = tmp_path / "map.toml"
    path.write_text(moved)
    register_map = load_register_map(path)
    device = DaqDevice(make_twin(), register_map, "SN-1")
    before = device.handle(4, 20, 1)
    device.handle(6, register_map["control"].address, 1, [register_map.control_codes["arm"]])
    assert device.handle(4, 20, 1) == before        # the input register at 20 untouched
    assert device.handle(3, 20, 1) == [register_map.states["armed"]]


def test_a_register_past_address_65535_is_refused_by_the_loader(tmp_path):
    text = Path(DEFAULT_MAP_PATH).read_text()
    state = MAP["state"]
    path = tmp_path / "map.toml"
    path.write_text(text.replace(f'[registers.state]\ntable = "input"\naddress = {state.address}',
                                 '[registers.state]\ntable = "input"\naddress = 65536'))
    with pytest.raises(InputError, match="Modbus addresses are 0..65535"):
        load_register_map(path)


def test_a_request_that_arrives_in_two_parts_behind_another_is_answered(daq_server):
    """pymodbus's ``send`` empties the receive buffer: the first part of a pipelined request
    that came in with the one before it was thrown away when that one was answered."""
    second = adu(2, READ_STATE)
    with socket.create_connection(daq_server.address) as sock:
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        sock.sendall(adu(1, READ_STATE) + second[:5])
        first = answers(sock, 1)
        time.sleep(0.05)
        sock.sendall(second[5:])
        rest = answers(sock, 1)
    assert [tid for tid, _ in first + rest] == [1, 2]


def test_frames_are_delimited_by_their_mbap_length(daq_server):
    """A frame of protocol id 1 is skipped and the reads behind it answered (they waited
    forever); an 8-byte request followed by one byte of the next keeps that byte (pymodbus's
    framer took a 9th byte into an 8-byte frame)."""
    with socket.create_connection(daq_server.address) as sock:
        sock.sendall(struct.pack(">HHHB", 1, 1, len(READ_STATE) + 1, 1) + READ_STATE
                     + adu(2, READ_STATE) + adu(3, READ_STATE))
        assert [tid for tid, _ in answers(sock, 2)] == [2, 3]
    second = adu(2, READ_STATE)
    with socket.create_connection(daq_server.address) as sock:
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        sock.sendall(adu(1, bytes([17])) + second[:1])          # report server id: 8 bytes
        first = answers(sock, 1)
        time.sleep(0.05)
        sock.sendall(second[1:])
        got = first + answers(sock, 1)
    assert [tid for tid, _ in got] == [1, 2] and got[0][1].startswith("91")
