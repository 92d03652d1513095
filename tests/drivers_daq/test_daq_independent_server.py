"""The DAQ driver against a Modbus server that is not pymodbus: modbus-tk (issue 14 item 6).

modbus-tk frames, decodes, checks and answers every request itself (``modbus_tk_peer``); the
register behaviour is the DAQ's, backed by the twin. The driver completes whole captures over
TCP (pipelined reads included) and over RTU on a pty, with the time base checked.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from daq_twin import CURRENT_A, SPEED_RPM
from modbus_tk_peer import modbus_tk_rtu, modbus_tk_tcp

from ripple_hil_drivers.daq_register_map import load_register_map
from ripple_hil_drivers.modbus_daq import (LEGACY_TRANSFER, IllegalAddress, IllegalValue, ModbusDaq,
                                ModbusRtuSettings, ModbusTcpSettings)
from ripple_hil_drivers.simulated.modbus_daq_server import DaqDevice
from hil.motor import TABLE_I

pytestmark = [pytest.mark.integration, pytest.mark.timeout(90),
              # modbus-tk 1.1.5's server loop calls threading.Event.isSet()
              pytest.mark.filterwarnings("ignore:isSet\\(\\) is deprecated:DeprecationWarning")]

ELECTRICAL_PERIOD_S = 60.0 / SPEED_RPM / TABLE_I.pole_pairs


@pytest.fixture
def device(twin):
    return DaqDevice(twin, load_register_map(), serial_number="TK-DAQ-0001")


def check_capture(capture, rate_hz: float, duration_s: float) -> None:
    assert len(capture) == round(duration_s * rate_hz)
    assert np.array_equal(capture["sample_counter"], np.arange(len(capture)))
    speed_rpm = np.polyfit(capture["time_s"], capture["rotor_angle_mech_rad"], 1)[0] * 60 / (
        2 * math.pi)
    assert speed_rpm == pytest.approx(SPEED_RPM, rel=0.01)
    theta_e = capture.meta["pole_pairs"] * capture["rotor_angle_mech_rad"]
    amplitude_a = 2.0 * abs(np.mean(capture["ia_a"] * np.exp(-1j * theta_e)))
    assert amplitude_a == pytest.approx(CURRENT_A, rel=0.15)


def test_capture_over_tcp_from_modbus_tk(device):
    duration_s = 2 * ELECTRICAL_PERIOD_S
    with modbus_tk_tcp(device) as address, ModbusDaq(ModbusTcpSettings(*address)) as daq:
        assert daq.identity()["serial_number"] == "TK-DAQ-0001"
        capture = daq.capture(duration_s, 20000, settle_s=0.01)
        transfer = capture.meta["daq_transfer"]
        assert (transfer["read_mode"], transfer["in_flight"], transfer["packed"]) == \
            ("auto_increment", 8, True)
        check_capture(capture, 20000, duration_s)
        with ModbusDaq(ModbusTcpSettings(*address), transfer=LEGACY_TRANSFER) as old:
            legacy = old.capture(ELECTRICAL_PERIOD_S, 20000, settle_s=0.0)
        assert len(legacy) == round(ELECTRICAL_PERIOD_S * 20000)
        # modbus-tk's own answers to what the map forbids
        with pytest.raises(IllegalAddress):
            daq._call("read a coil", daq._client.read_coils, 0, count=1)
        with pytest.raises(IllegalValue, match="write sample_rate_hz=0"):
            daq.write_registers(sample_rate_hz=0)


def test_capture_over_rtu_from_modbus_tk(device):
    duration_s = ELECTRICAL_PERIOD_S
    with modbus_tk_rtu(device) as port, ModbusDaq(ModbusRtuSettings(port)) as daq:
        capture = daq.capture(duration_s, 10000, settle_s=0.01)
        with pytest.raises(IllegalAddress):
            daq._call("read a coil", daq._client.read_coils, 0, count=1)
    assert capture.meta["daq_transfer"]["in_flight"] == 1
    check_capture(capture, 10000, duration_s)
