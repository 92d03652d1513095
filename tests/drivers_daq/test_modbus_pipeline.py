"""Pipelined Modbus TCP reads (``ripple_hil_drivers.modbus_pipeline``) against the simulated DAQ."""

from __future__ import annotations

import socket

import pytest

from ripple_hil_drivers.daq_register_map import load_register_map
from ripple_hil_drivers.modbus_daq import IllegalAddress
from ripple_hil_drivers.modbus_pipeline import ExceptionAnswer, read_input_registers_pipelined

pytestmark = [pytest.mark.integration, pytest.mark.timeout(60)]

MAP = load_register_map()
WINDOW = MAP["buffer_window"].address


@pytest.fixture
def finished(daq):
    """A finished 100-sample capture (all channels but the terminal voltage vab_v, + counter,
    full format: 700 words)."""
    daq.arm(10000, 100, 0.0, [c for c in daq.capture_channels() if c != "vab_v"], packed=False)
    daq.trigger()
    daq.wait_done(10.0)
    daq.write_registers(buffer_read_mode=MAP.buffer_read_modes["auto_increment"])
    return daq


def test_answers_come_back_in_request_order(finished, daq_server):
    with socket.create_connection(daq_server.address) as sock:
        chunks = read_input_registers_pipelined(sock, 1, WINDOW, [125, 125, 125, 125, 125, 75],
                                                depth=4, timeout_s=2.0)
    words = [w for chunk in chunks for w in chunk]
    assert [len(c) for c in chunks] == [125] * 5 + [75]
    frames = [words[i:i + 7] for i in range(0, 700, 7)]
    assert [frame[-1] for frame in frames] == list(range(100))     # the sample counter


def test_an_exception_answer_names_its_request(finished, daq_server):
    with socket.create_connection(daq_server.address) as sock:
        with pytest.raises(ExceptionAnswer) as caught:
            read_input_registers_pipelined(sock, 1, WINDOW, [125] * 7, depth=3, timeout_s=2.0)
    assert (caught.value.index, caught.value.code) == (5, 2)         # past the 700 words


def test_a_missing_answer_times_out(finished, daq_server):
    daq_server.fail_next("timeout")
    with socket.create_connection(daq_server.address) as sock:
        with pytest.raises(TimeoutError):
            read_input_registers_pipelined(sock, 1, WINDOW, [10, 10], depth=2, timeout_s=0.3)


def test_the_driver_types_the_error_and_reconnects(finished):
    with pytest.raises(IllegalAddress, match=r"^daq: read capture buffer \(7 windows, 8 in "
                                             r"flight\), window 5: Modbus exception 2"):
        finished._pipelined(WINDOW, [125] * 7, 8)
    assert finished.status()["state"] == "done"       # the next request opens a new connection


def test_depth_must_be_positive(daq_server):
    with socket.create_connection(daq_server.address) as sock:
        with pytest.raises(ValueError, match="depth=0"):
            read_input_registers_pipelined(sock, 1, WINDOW, [1], depth=0, timeout_s=1.0)


def test_32_requests_in_flight_arriving_together_are_all_answered(finished, daq_server):
    """32 requests of 12 bytes arrive in one segment (384 bytes): pymodbus's own handler drops
    a receive buffer beyond one ADU (260 bytes) without a word, and this read timed out."""
    with socket.create_connection(daq_server.address) as sock:
        chunks = read_input_registers_pipelined(sock, 1, WINDOW, [20] * 35, depth=32,
                                                timeout_s=2.0)
    words = [int(w) for chunk in chunks for w in chunk]
    assert [int(frame[-1]) for frame in (words[i:i + 7] for i in range(0, 700, 7))] == \
        list(range(100))
