"""The simulated DAQ answers every request exactly as its register map's header says.

Checked over Modbus TCP with pyModbusTCP's raw ``custom_request`` (not the project's driver, not
pymodbus's client), so each function code and quantity reaches the server as sent.
"""

from __future__ import annotations

import struct

import pytest
from pyModbusTCP.client import ModbusClient

from ripple_hil_drivers.daq_register_map import load_register_map

pytestmark = [pytest.mark.integration, pytest.mark.timeout(60)]

MAP = load_register_map()
WINDOW = MAP["buffer_window"].address


@pytest.fixture
def raw(daq_server):
    client = ModbusClient(*daq_server.address, unit_id=1, timeout=2.0, auto_open=True)
    yield client
    client.close()


def last_exception(client, pdu: bytes) -> int | None:
    """The exception code answered to ``pdu`` (None: a normal answer)."""
    answer = client.custom_request(pdu)
    return None if answer is not None else client.last_except


def unmapped(table: str) -> int:
    """The first address below 40 that no register of ``table`` covers."""
    covered = {a for r in MAP.registers.values() if r.table == table
               for a in range(r.address, r.address + r.words)}
    return min(set(range(40)) - covered)


@pytest.mark.parametrize("name, pdu, code", [
    ("read coils", struct.pack(">BHH", 1, 0, 1), 2),
    ("read discrete inputs", struct.pack(">BHH", 2, 0, 1), 2),
    ("write single coil", struct.pack(">BHH", 5, 0, 0xFF00), 2),
    ("write multiple coils", struct.pack(">BHHBB", 15, 0, 1, 1, 1), 2),
    ("mask write register", struct.pack(">BHHH", 22, 0, 0xFFFF, 0), 1),
    ("read/write multiple registers", struct.pack(">BHHHHBH", 23, 2, 1, 0, 1, 2, 0), 1),
    ("read exception status", bytes([7]), 1),
    ("diagnostics", struct.pack(">BHH", 8, 0, 0x1234), 1),
    ("get comm event counter", bytes([11]), 1),
    ("report server id", bytes([17]), 1),
    ("read device identification", bytes([43, 14, 1, 0]), 1),
    ("holding read of 126 registers", struct.pack(">BHH", 3, 0, 126), 3),
    ("input read of 0 registers", struct.pack(">BHH", 4, 0, 0), 3),
    ("write of 124 registers", struct.pack(">BHHB", 16, 0, 124, 248) + bytes(248), 3),
])
def test_function_codes_the_map_does_not_list_are_refused(raw, name, pdu, code):
    assert last_exception(raw, pdu) == code, name


def test_unlisted_addresses_and_gaps_answer_exception_2(raw):
    input_gap, holding_gap = unmapped("input"), unmapped("holding")
    state = MAP["state"].address
    assert last_exception(raw, struct.pack(">BHH", 4, input_gap, 1)) == 2
    assert last_exception(raw, struct.pack(">BHH", 4, input_gap - 1, 2)) == 2   # into a gap
    assert last_exception(raw, struct.pack(">BHH", 4, state, 1)) is None        # listed
    assert last_exception(raw, struct.pack(">BHH", 3, holding_gap, 1)) == 2
    assert last_exception(raw, struct.pack(">BHH", 6, holding_gap, 1)) == 2
    assert last_exception(raw, struct.pack(">BHH", 6, state, 0)) == 2    # input-only address
    assert last_exception(raw, struct.pack(">BHH", 4, WINDOW + 125, 1)) == 2    # past window
    assert last_exception(raw, struct.pack(">BHH", 3, WINDOW, 1)) == 2    # window is input


def test_listed_registers_answer_with_their_values(raw):
    model = MAP["model"]
    answer = raw.custom_request(struct.pack(">BHH", 4, model.address, model.words))
    assert answer[0] == 4 and answer[1] == 2 * model.words
    assert model.decode(list(struct.unpack(f">{model.words}H", answer[2:]))) == "RHIL-DAQ16"
    settle = MAP["settle_ms"]
    assert raw.custom_request(struct.pack(">BHH", 6, settle.address, 7)) is not None
    answer = raw.custom_request(struct.pack(">BHH", 3, settle.address, 1))
    assert struct.unpack(">H", answer[2:]) == (7,)


def test_out_of_range_values_answer_exception_3(raw):
    mode = MAP["buffer_read_mode"].address
    fmt = MAP["capture_format"].address
    assert last_exception(raw, struct.pack(">BHH", 6, mode, 7)) == 3
    assert last_exception(raw, struct.pack(">BHH", 6, fmt, 9)) == 3
    assert last_exception(raw, struct.pack(">BHH", 6, MAP["channel_mask"].address, 1 << 9)) == 3
    assert last_exception(raw, struct.pack(">BHH", 6, MAP["control"].address, 77)) == 3


def capture_done(client, samples: int) -> None:
    """Configure and finish a capture of ``samples`` samples of all channels (full format)."""
    words = (MAP["capture_format"].encode(0) + MAP["sample_rate_hz"].encode(10000)
             + MAP["samples"].encode(samples) + MAP["channel_mask"].encode(MAP.all_channels_mask)
             + MAP["settle_ms"].encode(0))
    assert client.write_multiple_registers(MAP["capture_format"].address, words)
    for code in ("arm", "trigger"):
        assert client.write_single_register(MAP["control"].address, MAP.control_codes[code])
    while client.read_input_registers(MAP["state"].address, 1) != [MAP.states["done"]]:
        pass


def test_auto_increment_reads_advance_by_the_count_read(raw):
    samples = 50                                 # 8 words per sample: 400 words
    capture_done(raw, samples)
    total = samples * raw.read_input_registers(MAP["words_per_sample"].address, 1)[0]
    assert raw.write_single_register(MAP["buffer_read_mode"].address,
                                     MAP.buffer_read_modes["paged"])
    paged = []
    for page in range(-(-total // 125)):
        assert raw.write_multiple_registers(MAP["buffer_page"].address, [0, page])
        paged += raw.read_input_registers(WINDOW, min(125, total - 125 * page))
    assert raw.write_single_register(MAP["buffer_read_mode"].address,
                                     MAP.buffer_read_modes["auto_increment"])
    auto = raw.read_input_registers(WINDOW, 100) + raw.read_input_registers(WINDOW, 125)
    assert raw.read_input_registers(WINDOW + 1, 10) is None and raw.last_except == 2
    auto += raw.read_input_registers(WINDOW, 125)       # the refused read did not advance it
    auto += raw.read_input_registers(WINDOW, total - len(auto))
    assert raw.read_input_registers(WINDOW, 1) is None and raw.last_except == 2   # past data
    assert len(auto) == total and auto == paged
    assert raw.write_multiple_registers(MAP["buffer_page"].address, [0, 2])     # rewind
    assert raw.read_input_registers(WINDOW, 10) == paged[250:260]
