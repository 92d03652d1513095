"""A DAQ that is not ours (issue 31 item 2): its capture sequence and its block transfer (the
standard Read File Record, function 0x14) are described by a register map file, not code.

Against what nobody here wrote: the frames of the Modbus Application Protocol Specification
v1.1b3 §6.14 example (file 4, record 1, two records: request ``14 07 06 0004 0001 0002``, answer
``14 06 05 06 0DFE 0020``) byte-exact from both ends, and modbus-tk's master (an independent
Modbus implementation) reading the simulated DAQ's file records.
"""

from __future__ import annotations

import dataclasses
import socket
import struct
import threading
from pathlib import Path

import numpy as np
import pytest
from modbus_tk import defines, modbus_tcp

from daq_twin import make_twin
from ripple_hil_drivers.daq_register_map import load_register_map
from ripple_hil_drivers.modbus_daq import IllegalAddress, IllegalFunction, ModbusDaq, \
    ModbusTcpSettings
from ripple_hil_drivers.simulated.modbus_daq_server import SimulatedDaq

FOREIGN_MAP = Path(__file__).resolve().parents[2] / "drivers" / "data" / \
    "daq_file_record_example.toml"
SPEC_REQUEST = bytes.fromhex("14 07 06 00 04 00 01 00 02")
SPEC_ANSWER = bytes.fromhex("14 06 05 06 0D FE 00 20")


def spec_map():
    """The foreign map with its buffer placed where the spec's example reads: file 4, record 1."""
    foreign = load_register_map(FOREIGN_MAP)
    return dataclasses.replace(foreign, transfer=dataclasses.replace(
        foreign.transfer, first_file=4, first_record=1))


def test_foreign_map_captures_exactly_what_the_shipped_map_does():
    """Two identical twins; the XDAQ-8 map (other names, addresses, codes, mask bits, buffer
    order, file records) and the shipped map give the same samples."""
    captures = {}
    for name, register_map in (("shipped", None), ("foreign", str(FOREIGN_MAP))):
        with SimulatedDaq(make_twin(seed=3), register_map=register_map) as server, \
                ModbusDaq(ModbusTcpSettings(*server.address), register_map=register_map) as daq:
            captures[name] = daq.capture(0.02, 20_000.0, settle_s=0.0)
    shipped, foreign = captures["shipped"], captures["foreign"]
    assert foreign.meta["daq_transfer"]["read_mode"] == "file_record"
    assert foreign.meta["daq_transfer"]["packed"] is False          # the map offers no packing
    words = len(foreign) * foreign.meta["daq_transfer"]["words_per_sample"]
    assert foreign.meta["daq_transfer"]["buffer_requests"] == -(-words // 120)
    assert foreign.meta["daq_model"] == "XDAQ-8"
    assert set(foreign.channels) == set(shipped.channels)
    for channel in shipped.channels:
        np.testing.assert_array_equal(foreign[channel], shipped[channel], err_msg=channel)


class _SpecPeer:
    """A raw Modbus TCP peer that records the request PDU and answers the spec's example."""

    def __init__(self) -> None:
        self.listener = socket.create_server(("127.0.0.1", 0))
        self.request = b""
        self.thread = threading.Thread(target=self._serve, daemon=True)
        self.thread.start()

    def _serve(self) -> None:
        connection, _ = self.listener.accept()
        with connection:
            connection.settimeout(5.0)
            header = connection.recv(7)
            tid, _, length, unit = struct.unpack(">HHHB", header)
            self.request = connection.recv(length - 1)
            connection.sendall(struct.pack(">HHHB", tid, 0, len(SPEC_ANSWER) + 1, unit)
                               + SPEC_ANSWER)
        self.listener.close()


def test_driver_request_and_decoding_are_the_spec_example_byte_exact():
    peer = _SpecPeer()
    daq = ModbusDaq(ModbusTcpSettings(*peer.listener.getsockname()[:2]), register_map=spec_map())
    with daq:
        words = daq._read_words(2, "file_record")
    peer.thread.join(5.0)
    assert peer.request == SPEC_REQUEST
    assert words.tolist() == [0x0DFE, 0x0020]


def _finished_capture(server: SimulatedDaq, words: list[int]) -> None:
    """Put ``words`` in the simulated DAQ's buffer as a finished capture (state done)."""
    device = server.device
    with device._lock:
        device._words = np.asarray(words, dtype=np.uint16)
        device._state = device.map.states["done"]


def test_simulated_daq_answers_the_spec_example_byte_exact():
    with SimulatedDaq(make_twin(), register_map=spec_map()) as server:
        _finished_capture(server, [0x0DFE, 0x0020, 0x1234])
        with socket.create_connection(server.address, timeout=5.0) as client:
            client.sendall(struct.pack(">HHHB", 7, 0, len(SPEC_REQUEST) + 1, 1) + SPEC_REQUEST)
            answer = b""
            while len(answer) < 7 + len(SPEC_ANSWER):
                answer += client.recv(256)
    assert answer == struct.pack(">HHHB", 7, 0, len(SPEC_ANSWER) + 1, 1) + SPEC_ANSWER


def test_modbus_tk_master_reads_the_simulated_daqs_file_records():
    """modbus-tk's own Read File Record request and decoder against the simulated DAQ."""
    with SimulatedDaq(make_twin(seed=4), register_map=str(FOREIGN_MAP)) as server:
        with ModbusDaq(ModbusTcpSettings(*server.address), register_map=str(FOREIGN_MAP)) as daq:
            daq.arm(20_000.0, 400, 0.0)
            daq.trigger()
            daq.wait_done(30.0)
            ours = daq._read_words(400 * 8, "file_record")
            master = modbus_tcp.TcpMaster(*server.address, timeout_in_sec=5.0)
            try:
                theirs = []
                for file, record, count in daq.map.transfer.requests(len(ours)):
                    (group,) = master.execute(1, defines.READ_FILE_RECORD,
                                              starting_address=(record,),
                                              quantity_of_x=(count,), number_file=(file,))
                    theirs += list(group)
            finally:
                master.close()
            daq.disarm()
    assert theirs == ours.tolist()
    assert len(set(theirs)) > 100           # a real capture, not a constant


def test_file_records_past_the_capture_and_on_a_register_window_map_are_refused():
    with SimulatedDaq(make_twin(), register_map=spec_map()) as server, \
            ModbusDaq(ModbusTcpSettings(*server.address), register_map=spec_map()) as daq:
        with pytest.raises(IllegalAddress):        # no finished capture: nothing to read
            daq._read_words(2, "file_record")
        _finished_capture(server, [1, 2, 3])
        assert daq._read_words(3, "file_record").tolist() == [1, 2, 3]
        with pytest.raises(IllegalAddress):
            daq._read_words(4, "file_record")
    with SimulatedDaq(make_twin()) as server, \
            ModbusDaq(ModbusTcpSettings(*server.address), register_map=spec_map()) as daq:
        with pytest.raises(IllegalFunction):       # the shipped DAQ offers no 0x14
            daq._read_words(2, "file_record")


@pytest.mark.parametrize("edit, words", [
    (("[roles]", "[roles]\ntrigger_register = \"ACQ_CMD\"\n#"), ["roles.trigger_register"]),
    (('control = "ACQ_CMD"', 'control = "ACQ_COMMAND"'), ["'ACQ_COMMAND'", "not a register"]),
    (('kind = "file_record"', 'kind = "fifo"'), ["transfer.kind", "'fifo'"]),
    (("words_per_request = 120", "words_per_request = 122"), ["words_per_request", "1..121"]),
    (("records_per_file = 10000", "records_per_file = 10001"), ["records_per_file"]),
])
def test_a_bad_capture_sequence_is_named(tmp_path, edit, words):
    from hil.errors import InputError

    path = tmp_path / "map.toml"
    path.write_text(FOREIGN_MAP.read_text().replace(*edit))
    with pytest.raises(InputError) as error:
        load_register_map(path)
    assert all(word in str(error.value) for word in words), error.value
