"""The simulated DAQ checked with a Modbus client that is not pymodbus (pyModbusTCP).

It proves the server speaks standard Modbus TCP (function codes 3, 4, 6, 16 and exception
responses), and that the pymodbus driver decodes exactly the buffer another client reads.
"""

from __future__ import annotations

import time

import numpy as np
import pytest
from pyModbusTCP.client import ModbusClient

from ripple_hil_drivers.daq_register_map import load_register_map

pytestmark = [pytest.mark.integration, pytest.mark.timeout(60)]

MAP = load_register_map()
EXC_ILLEGAL_ADDRESS, EXC_ILLEGAL_VALUE, EXC_BUSY = 2, 3, 6


@pytest.fixture
def other_client(daq_server):
    host, port = daq_server.address
    client = ModbusClient(host=host, port=port, unit_id=1, timeout=2.0, auto_open=True)
    yield client
    client.close()


def read(client, name):
    reg = MAP[name]
    reader = client.read_input_registers if reg.table == "input" else \
        client.read_holding_registers
    words = reader(reg.address, reg.words)
    assert words is not None, client.last_except_as_txt
    return reg.decode(words)


def write(client, name, value):
    reg = MAP[name]
    assert client.write_multiple_registers(reg.address, reg.encode(value)), \
        client.last_except_as_txt


def test_identity_strings_and_exception_codes(other_client):
    assert read(other_client, "model") == "RHIL-DAQ16"
    assert other_client.read_input_registers(500, 1) is None          # unmapped
    assert other_client.last_except == EXC_ILLEGAL_ADDRESS
    assert other_client.read_holding_registers(MAP["samples"].address, 1) is not None
    assert not other_client.write_single_register(MAP["sample_rate_hz"].address + 1, 0)
    assert other_client.last_except == EXC_ILLEGAL_VALUE                # 0 Hz
    reg = MAP["dyno_speed_setpoint_rpm"]
    assert not other_client.write_multiple_registers(reg.address, reg.encode(9000.0))
    assert other_client.last_except == EXC_ILLEGAL_VALUE
    assert not other_client.write_single_register(50, 1)               # unmapped holding
    assert other_client.last_except == EXC_ILLEGAL_ADDRESS


def test_capture_by_another_client_decodes_identically_in_the_driver(other_client, daq, twin):
    samples = 300
    mask = MAP.all_channels_mask
    write(other_client, "sample_rate_hz", 10000)
    write(other_client, "samples", samples)
    write(other_client, "channel_mask", mask)
    write(other_client, "settle_ms", 0)
    write(other_client, "control", MAP.control_codes["arm"])
    with twin.lock:
        write(other_client, "control", MAP.control_codes["trigger"])
        assert read(other_client, "state") == MAP.states["capturing"]
        assert other_client.read_input_registers(MAP["buffer_window"].address, 10) is None
        assert other_client.last_except == EXC_BUSY
    deadline = time.monotonic() + 10
    while read(other_client, "state") != MAP.states["done"]:
        assert time.monotonic() < deadline
        time.sleep(0.005)
    words_per_sample = read(other_client, "words_per_sample")
    total = samples * words_per_sample
    words = []
    for page in range(-(-total // 125)):
        write(other_client, "buffer_page", page)
        chunk = other_client.read_input_registers(MAP["buffer_window"].address,
                                                  min(125, total - len(words)))
        assert chunk is not None, other_client.last_except_as_txt
        words += chunk
    write(other_client, "buffer_page", total // 125 + 1)
    assert other_client.read_input_registers(MAP["buffer_window"].address, 1) is None
    assert other_client.last_except == EXC_ILLEGAL_ADDRESS       # past the captured data
    frames = np.array(words, dtype=np.uint16).reshape(samples, words_per_sample)

    capture = daq.read_buffer()           # the pymodbus driver reads the same finished capture
    column = 0
    for channel in MAP.channels:
        raw = channel.from_words(frames[:, column:column + channel.words])
        column += channel.words
        if channel is MAP.sample_counter:
            assert np.array_equal(capture["sample_counter"], np.arange(samples))
            assert np.array_equal(raw, np.arange(samples))
        elif channel.is_counter:
            assert np.array_equal(capture["encoder_counts"] & 0xFFFFFFFF, raw)
        else:
            assert np.array_equal(capture[channel.name], raw * channel.scale + channel.offset)
    assert column == words_per_sample


def test_a_refused_block_write_changes_no_setting(other_client):
    before = [read(other_client, name) for name in ("sample_rate_hz", "samples", "channel_mask")]
    words = MAP["sample_rate_hz"].encode(5000) + MAP["samples"].encode(77) + [0]   # mask 0
    assert not other_client.write_multiple_registers(MAP["sample_rate_hz"].address, words)
    assert other_client.last_except == EXC_ILLEGAL_VALUE
    assert [read(other_client, name) for name in ("sample_rate_hz", "samples",
                                                   "channel_mask")] == before
    write(other_client, "control", MAP.control_codes["arm"])     # the device agrees:
    write(other_client, "control", MAP.control_codes["trigger"])
    deadline = time.monotonic() + 10
    while read(other_client, "state") != MAP.states["done"]:
        assert time.monotonic() < deadline
        time.sleep(0.005)
    assert read(other_client, "samples_captured") == before[1] != 77
