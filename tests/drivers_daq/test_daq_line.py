"""RTU line settings: the bench file's ``[daq] parity`` / ``stopbits`` (default 8E1) and their use
by the driver and the simulated RTU DAQ."""

from __future__ import annotations

import termios
import tomllib

import pytest
from daq_twin import make_twin

from ripple_hil_drivers.modbus_daq import ModbusDaq, ModbusRtuSettings
from ripple_hil_drivers.serial_line import bits_per_char, line_for_port, pty_accepts_parity
from ripple_hil_drivers.simulated.modbus_daq_server import SimulatedDaq
from hil.config import BenchConfig, example_bench_path
from hil.errors import InputError

pytestmark = [pytest.mark.integration, pytest.mark.timeout(60)]

RTU = {"transport": "rtu", "serial_port": "/dev/ttyUSB1", "baudrate": 115200}


def real_bench(**daq) -> BenchConfig:
    path = example_bench_path("real-bench")
    d = tomllib.loads(path.read_text())
    d["daq"] = {k: v for k, v in d["daq"].items() if k not in ("host", "port")} | daq
    return BenchConfig.from_dict(d, source="bench.toml", base_dir=path.parent)


def test_bench_file_rtu_line_defaults_to_8e1_and_takes_8n2_and_8n1():
    default = real_bench(**RTU).daq
    assert (default.parity, default.stopbits) == ("E", 1)
    assert (real_bench(**RTU, parity="N", stopbits=2).daq.parity, 2) == ("N", 2)
    assert real_bench(**RTU, parity="N").daq.stopbits == 1
    assert real_bench(**RTU, parity="O").daq.parity == "O"


@pytest.mark.parametrize("change, message", [
    ({"parity": "X"}, r"daq\.parity = 'X' is not allowed; allowed: 'E', 'O', 'N'"),
    ({"parity": "even"}, r"daq\.parity = 'even' is not allowed"),
    ({"stopbits": 3}, r"daq\.stopbits = 3 is not allowed; allowed: 1, 2"),
    ({"requests_in_flight": 4}, r"daq\.requests_in_flight is only used with transport = 'tcp'"),
])
def test_bad_rtu_line_settings_name_the_key_and_the_allowed_values(change, message):
    with pytest.raises(InputError, match=message):
        real_bench(**RTU, **change)


def test_line_settings_on_a_tcp_daq_are_refused():
    with pytest.raises(InputError, match=r"daq\.parity is only used with transport = 'rtu'"):
        real_bench(transport="tcp", host="10.0.0.2", port=502, parity="N")
    with pytest.raises(InputError, match=r"daq\.requests_in_flight = 0 is out of range"):
        real_bench(transport="tcp", host="10.0.0.2", port=502, requests_in_flight=0)


def test_driver_settings_refuse_bad_parity_and_stop_bits():
    assert (ModbusRtuSettings("/dev/ttyUSB1").parity, ModbusRtuSettings("/dev/x").stopbits) \
        == ("E", 1)
    with pytest.raises(InputError, match="daq parity='e'; allowed E, O, N"):
        ModbusRtuSettings("/dev/ttyUSB1", parity="e")
    with pytest.raises(InputError, match="daq stopbits=1.5; allowed 1 or 2"):
        ModbusRtuSettings("/dev/ttyUSB1", stopbits=1.5)


def test_a_real_serial_port_is_opened_with_the_parity_asked():
    # not a pseudo-terminal: the driver hands the parity to pyserial unchanged (no port opened)
    daq = ModbusDaq(ModbusRtuSettings("/dev/ttyUSB7", parity="O", stopbits=2))
    assert (daq._client.comm_params.parity, daq._client.comm_params.stopbits) == ("O", 2)
    assert daq.line_note == ""


@pytest.mark.parametrize("parity, stopbits", [("E", 1), ("N", 2), ("N", 1), ("O", 1)])
def test_capture_over_rtu_with_each_line_setting(parity, stopbits):
    twin = make_twin()
    with SimulatedDaq.rtu(twin, parity=parity, stopbits=stopbits) as server, \
            ModbusDaq(ModbusRtuSettings(server.port, parity=parity, stopbits=stopbits),
                      timeout_s=1.0) as daq:
        capture = daq.capture(0.01, 5000, settle_s=0.0)
        line = daq._client.socket                       # the pyserial port the driver opened
        client_cflag = termios.tcgetattr(line.fileno())[2]
        server_params = server._server.comm_params
    assert len(capture) == 50
    assert bool(client_cflag & termios.CSTOPB) == (stopbits == 2)   # a pty keeps stop bits
    assert line.stopbits == server_params.stopbits == stopbits
    # a pty carries bytes, not bits: where this kernel refuses parity on a pty, both ends open
    # it without parity and say so; elsewhere both ends use the parity asked
    expected = parity if (parity == "N" or pty_accepts_parity()) else "N"
    assert line.parity == server_params.parity == expected
    assert bool(daq.line_note) == (expected != parity)
    assert ("daq_line_note" in capture.meta) == (expected != parity)


def test_pacing_counts_the_parity_and_stop_bits():
    assert bits_per_char("E", 1) == bits_per_char("N", 2) == 11
    assert bits_per_char("N", 1) == 10
    assert bits_per_char("O", 2) == 12
    assert line_for_port("/dev/ttyS0", "E") == ("E", "")
