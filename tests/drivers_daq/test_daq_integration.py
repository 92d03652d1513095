"""The simulated DAQ driven through pymodbus over TCP loopback and RTU on a pty."""

from __future__ import annotations

import math
import threading

import numpy as np
import pytest
from daq_twin import CURRENT_A, SPEED_RPM, make_twin

from ripple_hil_drivers.daq_register_map import DEFAULT_MAP_PATH, load_register_map
from ripple_hil_drivers.errors import DeviceFault, InstrumentError, InstrumentTimeout
from ripple_hil_drivers.modbus_daq import (DeviceBusy, DeviceFailure, IllegalValue, ModbusDaq,
                                ModbusRtuSettings, ModbusTcpSettings)
from ripple_hil_drivers.simulated.modbus_daq_server import SimulatedDaq
from hil.errors import InputError
from hil.motor import TABLE_I

pytestmark = [pytest.mark.integration, pytest.mark.timeout(60)]

ELECTRICAL_PERIOD_S = 60.0 / SPEED_RPM / TABLE_I.pole_pairs     # 30 ms at 1000 rpm
RATE_HZ = 20000


def order_amplitude(capture, channel: str, order: int) -> float:
    """Amplitude of the electrical-order component of a channel (whole revolutions captured)."""
    theta_e = capture.meta["pole_pairs"] * capture["rotor_angle_mech_rad"]
    return float(2.0 * abs(np.mean(capture[channel] * np.exp(-1j * order * theta_e))))


def test_identity_and_dyno_speed_reference(daq, twin):
    identity = daq.identity()
    assert identity["model"] == "RHIL-DAQ16"
    assert identity["serial_number"] == "SIM-DAQ-0001"
    assert identity["encoder_counts_per_rev"] == 7200
    daq.set_dyno_speed_rpm(-1234.5)
    assert twin.speed_rpm == -1234.5
    assert daq.dyno_speed_rpm() == -1234.5
    with pytest.raises(InputError, match="3000"):
        daq.set_dyno_speed_rpm(3500)


def test_capture_is_in_si_units_and_consistent_with_the_operating_point(daq):
    capture = daq.capture(2 * ELECTRICAL_PERIOD_S, RATE_HZ)
    n = round(2 * ELECTRICAL_PERIOD_S * RATE_HZ)
    assert len(capture) == n
    assert set(capture.channels) == {"time_s", "ia_a", "ib_a", "encoder_counts",
                                     "rotor_angle_mech_rad", "torque_nm", "dc_bus_v",
                                     "sample_counter", "vab_v"}
    assert capture.meta["sample_rate_hz"] == RATE_HZ
    assert capture.meta["pole_pairs"] == TABLE_I.pole_pairs
    assert capture.meta["daq_lsb"]["ia_a"] == 0.005
    assert capture.meta["daq_lsb"]["rotor_angle_mech_rad"] == pytest.approx(2 * math.pi / 7200)
    assert np.allclose(np.diff(capture["time_s"]), 1.0 / RATE_HZ)
    speed_rpm = np.polyfit(capture["time_s"], capture["rotor_angle_mech_rad"], 1)[0] * 60 / (
        2 * math.pi)
    assert speed_rpm == pytest.approx(SPEED_RPM, rel=0.01)
    assert np.median(capture["dc_bus_v"]) == pytest.approx(TABLE_I.dc_bus_v, rel=0.1)
    assert order_amplitude(capture, "ia_a", 1) == pytest.approx(CURRENT_A, rel=0.15)
    assert np.mean(capture["torque_nm"]) == pytest.approx(
        TABLE_I.torque_constant_nm_per_a * CURRENT_A, rel=0.2)
    assert daq.status()["state"] == "idle"      # capture() disarms


def test_injected_phase_a_offset_shows_in_the_dc_current_and_order_1_torque(daq, twin):
    duration_s = 3 * ELECTRICAL_PERIOD_S
    baseline = daq.capture(duration_s, RATE_HZ, settle_s=0.05)
    offset_a = 1.0
    twin.set_injection(ia_offset_a=offset_a)
    faulty = daq.capture(duration_s, RATE_HZ, settle_s=0.05)
    dc_shift_a = np.mean(faulty["ia_a"]) - np.mean(baseline["ia_a"])
    # the drive regulates the sensed current, so the real current carries -offset as dc
    assert dc_shift_a == pytest.approx(-offset_a, abs=0.3 * offset_a)
    ripple_before = order_amplitude(baseline, "torque_nm", 1)
    ripple_after = order_amplitude(faulty, "torque_nm", 1)
    assert ripple_after > 3 * ripple_before
    assert ripple_after > 20 * baseline.meta["daq_lsb"]["torque_nm"]


def test_capture_over_rtu_on_a_pseudo_terminal(twin):
    with SimulatedDaq.rtu(twin, baudrate=115200) as server, \
            ModbusDaq(ModbusRtuSettings(server.port), timeout_s=1.0) as daq:
        assert daq.identity()["model"] == "RHIL-DAQ16"
        capture = daq.capture(ELECTRICAL_PERIOD_S, 5000)
    assert len(capture) == round(ELECTRICAL_PERIOD_S * 5000)
    assert order_amplitude(capture, "ia_a", 1) == pytest.approx(CURRENT_A, rel=0.15)


def test_device_is_busy_while_the_twin_runs_the_capture(daq, twin):
    daq.arm(RATE_HZ, 200, settle_s=0.0)
    with twin.lock:                       # hold the simulation: the capture cannot finish
        daq.trigger()
        assert daq.status()["state"] == "capturing"
        with pytest.raises(DeviceBusy, match="exception 6"):
            daq.arm(RATE_HZ, 100)
        with pytest.raises(DeviceBusy):
            daq.write_registers(buffer_page=0)
        with pytest.raises(InstrumentTimeout, match="wait for capture"):
            daq.wait_done(0.05)
        daq.set_dyno_speed_rpm(1500.0)      # the analog output is not blocked by a capture
        assert twin.speed_rpm == SPEED_RPM  # the dyno takes it when the window is simulated
    daq.wait_done(10.0)
    assert len(daq.read_buffer()) == 200
    assert twin.speed_rpm == 1500.0
    assert daq.dyno_speed_rpm() == 1500.0
    daq.disarm()


def test_trigger_without_arm_and_reading_an_empty_buffer_are_refused(daq):
    with pytest.raises(IllegalValue, match="daq: write control=2"):
        daq.trigger()
    with pytest.raises(DeviceFault, match="no finished capture"):
        daq.read_buffer()


def test_asking_more_than_the_buffer_holds_sets_the_overrun_flag(tmp_path, twin):
    small = tmp_path / "small.toml"
    small.write_text(DEFAULT_MAP_PATH.read_text().replace(
        "buffer_capacity_samples = 200000", "buffer_capacity_samples = 100"))
    register_map = load_register_map(small)
    with SimulatedDaq(twin, register_map=register_map) as server, \
            ModbusDaq(ModbusTcpSettings(*server.address), register_map=register_map) as daq:
        daq.arm(RATE_HZ, 150, settle_s=0.0)
        daq.trigger()
        with pytest.raises(DeviceFault, match="overrun"):
            daq.wait_done(10.0)
        assert daq.status()["overrun"]
        assert daq.status()["samples_captured"] == 100
        daq.disarm()
        with pytest.raises(InputError, match="1..100"):
            daq.capture(0.01, RATE_HZ)        # 200 samples: refused before arming


@pytest.mark.parametrize("kind, error", [("exception", DeviceFailure),
                                         ("timeout", InstrumentTimeout),
                                         ("disconnect", InstrumentError)])
def test_injected_transport_faults_raise_typed_errors_and_the_link_recovers(
        daq_server, kind, error):
    with ModbusDaq(ModbusTcpSettings(*daq_server.address), timeout_s=0.3) as daq:
        daq_server.fail_next(kind)
        with pytest.raises(error, match="^daq: read model"):
            daq.identity()
        assert daq.identity()["model"] == "RHIL-DAQ16"


@pytest.mark.parametrize("kind", ["timeout", "disconnect"])
def test_an_unanswered_request_over_rtu_leaves_the_line_usable(kind):
    """RTU has no connection to drop: "disconnect" closed pymodbus's serial handler, which is
    never reopened, and every later request timed out (review h-19)."""
    with SimulatedDaq.rtu(make_twin()) as server, \
            ModbusDaq(ModbusRtuSettings(server.port), timeout_s=0.3) as daq:
        server.fail_next(kind)
        with pytest.raises(InstrumentTimeout):
            daq.identity()
        assert daq.identity()["model"] == "RHIL-DAQ16"


def test_a_fault_during_capture_leaves_the_daq_disarmed(daq, daq_server):
    daq.identity()
    daq_server.fail_next("exception")           # refuses the configuration write
    with pytest.raises(DeviceFailure):
        daq.capture(0.005, RATE_HZ)
    assert daq.status()["state"] == "idle"
    assert len(daq.capture(0.005, RATE_HZ)) == 100


def test_stopping_the_server_while_a_client_is_connected_does_not_hang():
    twin = make_twin()
    server = SimulatedDaq(twin).start()
    daq = ModbusDaq(ModbusTcpSettings(*server.address), timeout_s=0.3).connect()
    daq.identity()
    stopper = threading.Thread(target=server.stop)
    stopper.start()
    stopper.join(10.0)
    assert not stopper.is_alive()
    with pytest.raises(InstrumentError):
        daq.identity()
    daq.close()


def test_the_device_reports_the_twins_encoder_and_the_angle_uses_it():
    from hil.sim import DriveTwin
    from hil.sim.config import DriveConfig, SensorModel
    twin = DriveTwin(DriveConfig(sensors=SensorModel(encoder_counts_per_rev=1000),
                                 speed_rpm=SPEED_RPM))
    with SimulatedDaq(twin) as server, ModbusDaq(ModbusTcpSettings(*server.address)) as daq:
        assert daq.identity()["encoder_counts_per_rev"] == 1000
        capture = daq.capture(2 * ELECTRICAL_PERIOD_S, RATE_HZ)
    assert capture.meta["encoder_counts_per_rev"] == 1000
    counts_per_s = np.polyfit(capture["time_s"], capture["encoder_counts"], 1)[0]
    assert counts_per_s == pytest.approx(SPEED_RPM / 60 * 1000, rel=0.01)
    speed_rpm = np.polyfit(capture["time_s"], capture["rotor_angle_mech_rad"], 1)[0] * 60 / (
        2 * math.pi)
    assert speed_rpm == pytest.approx(SPEED_RPM, rel=0.01)


def test_connecting_to_a_closed_port_names_the_instrument():
    import socket
    with socket.socket() as probe:            # a port that was free a moment ago
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    with pytest.raises(InstrumentError, match="^daq: connect"):
        ModbusDaq(ModbusTcpSettings("127.0.0.1", port), timeout_s=0.3).connect()
