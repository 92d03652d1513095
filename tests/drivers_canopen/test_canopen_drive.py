"""Integration: the Cia402Drive driver against the simulated drive node over a python-can bus.

Both sides use their real stacks (canopen master / canopen slave) on python-can's ``virtual``
interface; injections are checked where they must land: ``twin.injection``.
"""

from __future__ import annotations

import math
import re
import threading
import time

import can
import pytest

from ripple_hil_drivers.cia402 import Cia402Drive
from ripple_hil_drivers.errors import (DeviceFault, HeartbeatLost, InjectionRangeError, InstrumentTimeout,
                            LimitError)
from hil.errors import InputError
from hil.motor import TABLE_I
from canopen_helpers import POLL_SLACK_S, NON_DEFAULT, eventually, poll_until_heartbeat_lost

pytestmark = [pytest.mark.integration, pytest.mark.timeout(30)]



def test_identity_and_initial_state(drive):
    identity = drive.identity()
    assert identity["serial"] == 0x1234
    assert identity["product"] == 0x402
    assert identity["firmware"] == "ripple-hil-drive 0.1.0"
    assert drive.state == "SWITCH ON DISABLED"
    drive.check_health()


def test_enable_quick_stop_disable_reach_the_twin(drive, twin):
    drive.enable()
    assert drive.state == "OPERATION ENABLED" and twin.enabled
    assert drive.quick_stop() == "QUICK STOP ACTIVE"
    assert not twin.enabled
    assert drive.disable() == "SWITCH ON DISABLED"
    drive.enable()
    assert twin.enabled
    assert drive.disable() == "SWITCH ON DISABLED"
    assert not twin.enabled


@pytest.mark.parametrize("knob", sorted(NON_DEFAULT))
def test_each_injection_reaches_the_twin_and_reads_back(drive, twin, knob):
    drive.enable()
    drive.set_injection(**{knob: NON_DEFAULT[knob]})
    assert getattr(twin.injection, knob) == pytest.approx(NON_DEFAULT[knob])
    read_back = drive.injection()
    assert read_back[knob] == pytest.approx(NON_DEFAULT[knob])
    others = {k: v for k, v in read_back.items() if k != knob}
    assert all(v == drive.injection_limits()[k][2] for k, v in others.items())


def test_restore_defaults_resets_every_knob_in_the_twin(drive, twin):
    drive.set_injection(**NON_DEFAULT)
    assert twin.injection.dead_time_s == pytest.approx(2.5e-6)
    drive.restore_injection_defaults()
    assert twin.injection == type(twin.injection)()
    assert drive.injection()["encoder_decimation"] == 1


def test_out_of_range_injection_is_refused_before_anything_is_sent(drive, twin, bus_settings):
    drive.set_injection(ia_offset_a=1.0)
    with can.Bus(interface="virtual", channel=bus_settings.channel) as spy:
        with pytest.raises(InjectionRangeError, match=r"ib_offset_a.*-20\.\.20") as info:
            drive.set_injection(ia_offset_a=2.0, ib_offset_a=25.0)
        assert spy.recv(timeout=0.05) is None or all(
            m.arbitration_id != 0x605 for m in _drain(spy))
    assert isinstance(info.value, LimitError) and isinstance(info.value, InputError)
    assert twin.injection.ia_offset_a == 1.0  # the valid knob of the refused call was not sent
    with pytest.raises(InputError, match="unknown injection knob"):
        drive.set_injection(offset_a_pu=0.01)


def test_value_the_drive_rejects_becomes_a_range_error(drive, twin):
    # word length 1..5 is inside the EDS limits 0..32 but not allowed: the drive aborts 0x06090030
    with pytest.raises(InjectionRangeError, match="word_length_bits"):
        drive.set_injection(word_length_bits=3)
    assert twin.injection.word_length_bits == 0


def test_current_and_torque_commands(drive, twin):
    drive.set_current_command_a(12.345)
    assert twin.current_command_a == pytest.approx(12.345)
    kt = TABLE_I.torque_constant_nm_per_a
    drive.set_target_torque_nm(1.0)
    rated_nm = 4.879
    assert twin.current_command_a == pytest.approx(round(1000 / rated_nm) * rated_nm / 1000 / kt)
    with pytest.raises(InjectionRangeError, match="current command"):
        drive.set_current_command_a(150.0)
    with pytest.raises(InjectionRangeError):
        drive.set_target_torque_nm(-0.5)
    drive.set_target_velocity_rpm(1200)
    assert twin.speed_rpm == 1200


def test_modes_of_operation(drive):
    drive.set_mode("profile_torque")
    assert drive.mode() == "profile_torque"
    drive.set_mode("cyclic_synchronous_torque")
    assert drive.mode() == "cyclic_synchronous_torque"
    with pytest.raises(InputError, match="not supported by the drive"):
        drive.set_mode("profile_position")   # in the CiA 402 list, not in 0x6502
    with pytest.raises(InputError, match="not one of"):
        drive.set_mode("warp_drive")


def test_actual_values_come_from_remapped_tpdos(drive, twin):
    # The EDS default maps only the position to TPDO2; the driver remapped it to torque+velocity,
    # so these values arriving proves the node honours a master's remap.
    drive.set_target_velocity_rpm(600)
    drive.set_current_command_a(20.0)
    drive.enable()
    with twin.lock:
        twin.advance(0.01, 10_000)
    expected = twin.status()
    deadline = time.monotonic() + 2.0
    while True:
        try:
            actual = drive.actual()
        except InstrumentTimeout:  # TPDOs older than the advance (the twin was busy)
            actual = {"position_counts": None}
        if actual["position_counts"] == int(expected["position_counts"]) or time.monotonic() > deadline:
            break
        time.sleep(0.01)
    assert actual["position_counts"] is not None, "no fresh TPDOs within 2 s after advance"
    assert actual["state"] == "OPERATION ENABLED", (actual, expected)
    assert actual["velocity_rpm"] == pytest.approx(expected["speed_rpm"], abs=0.5)
    assert actual["position_counts"] == int(expected["position_counts"])
    assert actual["torque_nm"] == pytest.approx(expected["torque_em_nm"], abs=0.0049)
    assert actual["position_counts"] != 0


def test_emcy_fault_and_working_fault_reset(drive, sim_drive, twin):
    drive.enable()
    sim_drive.raise_fault(code=0x2310, text="overc")
    assert eventually(lambda: drive.state == "FAULT")
    assert not twin.enabled
    assert eventually(lambda: drive.last_emcy is not None)
    assert drive.last_emcy.code == 0x2310
    with pytest.raises(DeviceFault, match="0x2310"):
        drive.check_health()
    with pytest.raises(DeviceFault, match="fault_reset"):
        drive.enable()
    assert drive.fault_reset() == "SWITCH ON DISABLED"
    assert drive.last_emcy is None
    drive.check_health()
    drive.enable()
    assert twin.enabled


def test_synchronised_health_check_sees_an_emcy_sent_just_before_it(drive, sim_drive):
    """The check right after a capture: the drive faults and the check follows at once. With
    ``synchronise`` the statusword's SDO reply comes after the EMCY on the bus, so the check
    fails every time (without it, whether the EMCY was already dispatched is a race)."""
    for attempt in range(20):
        drive.enable()
        sim_drive.raise_fault(code=0x4310, text=f"hot{attempt}")
        with pytest.raises(DeviceFault, match="0x4310"):
            drive.check_health(synchronise=True)
        assert drive.fault_reset() == "SWITCH ON DISABLED"
        drive.check_health(synchronise=True)


def heartbeat_frames(spy, node_id: int, duration_s: float) -> list[float]:
    """Time stamps (s, the bus clock) of the node's heartbeat frames seen on ``spy``."""
    stamps, deadline = [], time.monotonic() + duration_s
    while (remaining := deadline - time.monotonic()) > 0:
        message = spy.recv(timeout=remaining)
        if message is not None and message.arbitration_id == 0x700 + node_id:
            stamps.append(message.timestamp)
    return stamps


def test_heartbeat_loss_is_detected_at_the_consumer_time(drive, sim_drive, bus_settings):
    """CiA 301: lost when silent for the consumer time; tolerance one producer period."""
    timeout_s, period_s = drive.heartbeat_timeout_s, drive.producer_heartbeat_ms / 1000
    drive.check_health()
    with can.Bus(interface="virtual", channel=bus_settings.channel) as spy:
        heartbeat_frames(spy, 5, 2 * period_s)
        sim_drive.stop_heartbeat()
        stamps = heartbeat_frames(spy, 5, 0.3 * period_s)   # one may still be in flight
        last = stamps[-1] if stamps else None
        detected, message = poll_until_heartbeat_lost(drive, clock=time.time)
    if last is None:        # the stop came right after a frame: take it from the drive's view
        last = detected - (time.monotonic() - drive._last_heartbeat)
    silence_s = detected - last
    assert timeout_s - period_s <= silence_s <= timeout_s + period_s + POLL_SLACK_S, silence_s
    stated_s = float(re.search(r"for (\d+\.\d+) s", message).group(1))
    assert stated_s == pytest.approx(silence_s, abs=POLL_SLACK_S)
    assert f"consumer time {timeout_s:g} s" in message and "node 5" in message
    with pytest.raises(HeartbeatLost):
        drive.enable()


def test_a_heartbeat_within_one_producer_period_after_the_consumer_time_is_late_not_lost(
        drive, sim_drive):
    timeout_s, period_s = drive.heartbeat_timeout_s, drive.producer_heartbeat_ms / 1000
    sim_drive.stop_heartbeat()
    last = drive._last_heartbeat
    time.sleep(max(0.0, last + timeout_s + 0.25 * period_s - time.monotonic()))
    timer = threading.Timer(0.4 * period_s, sim_drive.resume_heartbeat)
    timer.start()
    try:
        drive.check_health()  # waits up to one producer period past the consumer time
    finally:
        timer.join()
    sim_drive.stop_heartbeat()
    time.sleep(timeout_s + 1.5 * period_s)
    with pytest.raises(HeartbeatLost):
        drive.check_health()


def test_sdo_is_not_answered_while_nmt_stopped(drive, sim_drive):
    drive.node.nmt.send_command(0x02)  # STOPPED
    assert eventually(lambda: sim_drive.node.nmt.state == "STOPPED")
    with pytest.raises(InstrumentTimeout, match="no SDO answer"):
        drive.sdo_read(0x1000)
    drive.node.nmt.send_command(0x01)
    assert eventually(lambda: sim_drive.node.nmt.state == "OPERATIONAL")
    assert drive.sdo_read(0x1000) & 0xFFFF == 402


def test_nmt_stop_while_enabled_switches_the_gates_off(drive, twin):
    drive.enable()
    drive.node.nmt.send_command(0x02)
    assert eventually(lambda: not twin.enabled)


def test_reconnect_to_an_operational_node(drive, sim_drive, bus_settings, twin):
    # canopen's BaseNode402.setup_pdos asserts the NMT state with a substring test; this driver
    # configures PDOs itself in PRE-OPERATIONAL, whatever state it finds the node in.
    drive.close()
    with Cia402Drive(bus_settings, node_id=5) as again:
        again.enable()
        assert twin.enabled
        again.disable()


def test_no_drive_on_the_bus_times_out(bus_settings):
    lonely = Cia402Drive(bus_settings, node_id=9, sdo_timeout_s=0.05)
    with pytest.raises(InstrumentTimeout, match="device type"):
        lonely.connect()
    assert lonely.network is None


def test_bad_settings_are_input_errors(bus_settings):
    with pytest.raises(InputError, match="node_id"):
        Cia402Drive(bus_settings, node_id=0)
    with pytest.raises(InputError, match="heartbeat_timeout_s"):
        Cia402Drive(bus_settings, heartbeat_timeout_s=0)


def _drain(bus):
    frames = []
    while (msg := bus.recv(timeout=0.01)) is not None:
        frames.append(msg)
    return frames


def test_nan_current_command_is_refused(drive):
    with pytest.raises(InjectionRangeError):
        drive.set_current_command_a(math.nan)


def test_a_drive_without_the_optional_identity_objects_connects(twin, bus_settings, tmp_path):
    """CiA 301: 0x1008 / 0x100A are optional; 0x1018 is the identity the driver needs."""
    from ripple_hil_drivers.simulated.drive_node import SimulatedDrive
    from eds_text import drop_objects, shipped_text, write
    lean = write(drop_objects(shipped_text(), [0x1008, 0x100A]), tmp_path / "lean.eds")
    with SimulatedDrive(twin, bus_settings, node_id=5, eds_path=lean, serial_number=7), \
            Cia402Drive(bus_settings, node_id=5, eds_path=lean) as drive:
        identity = drive.identity()
        drive.enable()
        assert twin.enabled
    assert identity == {"vendor": 0, "product": 0x402, "revision": 0x00010000, "serial": 7}


def test_writing_the_rated_torque_rescales_the_torque_commands(drive, twin):
    """0x6076 is rw (CiA 402): the per-mille target torque follows the value written."""
    drive.sdo_write(0x6076, 0, 2000)                      # 2 N*m rated
    drive.set_target_torque_nm(1.0)                       # 500 per mille
    assert drive.sdo_read(0x6071) == 500
    assert twin.current_command_a == pytest.approx(1.0 / TABLE_I.torque_constant_nm_per_a)
