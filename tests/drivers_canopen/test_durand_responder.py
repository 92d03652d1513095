"""Integration: ``Cia402Drive`` against an independent CANopen responder built with durand.

The responder (``durand_drive``) uses another CANopen implementation than the driver's
python-canopen, holds the dictionary of the shipped EDS (read with configparser), and answers
the CiA 402 state machine from the standard's table written out in ``cia402_table``. So a
misreading of CiA 301/402 shared by the driver and the project's own simulated drive shows up.
"""

from __future__ import annotations

import re
import time

import pytest

from ripple_hil_drivers.canopen_eds import injection_objects
from ripple_hil_drivers.cia402 import Cia402Drive
from ripple_hil_drivers.errors import DeviceFault, InjectionRangeError
from canopen_helpers import POLL_SLACK_S, NON_DEFAULT, eventually, poll_until_heartbeat_lost
from durand_drive import DurandDrive

pytestmark = [pytest.mark.integration, pytest.mark.timeout(60)]

NODE = 5


@pytest.fixture
def responder(bus_settings):
    with DurandDrive(bus_settings.channel, NODE, serial_number=0xD0D) as node:
        yield node


@pytest.fixture
def driver(responder, bus_settings):
    with Cia402Drive(bus_settings, node_id=NODE, heartbeat_timeout_s=0.5) as drive:
        yield drive


def test_connects_and_identifies(driver, responder):
    assert driver.identity() == {"vendor": 0, "product": 0x402, "revision": 0x00010000,
                                 "serial": 0xD0D, "device_name": "ripple-hil PMSM drive",
                                 "firmware": "ripple-hil-drive 0.1.0"}
    assert responder.node.nmt.state == 5                   # OPERATIONAL, set by the driver
    assert responder.od.read(0x1017, 0) == driver.producer_heartbeat_ms
    driver.check_health()


def test_walks_the_state_machine(driver, responder):
    assert driver.state == "SWITCH ON DISABLED"
    driver.enable()                                        # by RPDO1: shutdown, switch on, enable
    assert responder.state == driver.state == "OPERATION ENABLED"
    assert driver.quick_stop() == "QUICK STOP ACTIVE" == responder.state
    assert driver.disable() == "SWITCH ON DISABLED" == responder.state
    driver.sdo_write(0x6040, 0, 0x0006)                    # READY TO SWITCH ON, then 3 + 4
    driver.sdo_write(0x6040, 0, 0x000F)
    assert responder.state == "OPERATION ENABLED" and driver.state == "OPERATION ENABLED"
    driver.set_mode("cyclic_synchronous_torque")
    assert driver.mode() == "cyclic_synchronous_torque"


def test_writes_and_reads_back_injections(driver, responder):
    driver.set_injection(**NON_DEFAULT)
    objects = injection_objects()
    held = responder.injection_counts()
    assert {knob: held[obj.index] for knob, obj in objects.items()} == {
        knob: objects[knob].to_count(value) for knob, value in NON_DEFAULT.items()}
    assert driver.injection() == pytest.approx(NON_DEFAULT)
    driver.restore_injection_defaults()
    assert driver.injection() == {knob: obj.default_si for knob, obj in objects.items()}


def test_the_responders_limit_abort_is_a_range_error(driver, responder):
    """Past the driver's own check: durand's SDO server aborts 0x06090031 (value too high)."""
    with pytest.raises(InjectionRangeError, match="refused the value"):
        driver.sdo_write(0x2001, 0, 20001)
    assert responder.injection_counts()[0x2001] == 0


def test_actual_values_arrive_by_tpdo(driver, responder):
    responder.actual.update({0x6077: 500, 0x606C: 1200, 0x6064: -7200})
    assert eventually(lambda: driver.actual()["velocity_rpm"] == 1200.0)
    actual = driver.actual()
    assert actual["torque_nm"] == pytest.approx(0.5 * 4.879)      # 500 per mille of 0x6076
    assert actual["position_counts"] == -7200 and actual["age_s"] < 0.1


def test_sees_an_emcy_and_resets_the_fault(driver, responder):
    driver.enable()
    responder.raise_fault(0x2310, 0x03, b"overc")
    assert eventually(lambda: driver.last_emcy is not None)
    assert (driver.last_emcy.code, driver.last_emcy.register) == (0x2310, 0x03)
    with pytest.raises(DeviceFault, match="EMCY 0x2310"):
        driver.check_health()
    assert driver.fault_reset() == "SWITCH ON DISABLED" == responder.state
    driver.check_health()


def test_a_synchronised_check_and_the_reset_see_a_fault_at_once(driver, responder):
    """The independent responder faults and the driver checks at once (the check after a
    capture): the SDO reply orders the EMCY before it, and fault_reset reads FAULT over SDO
    rather than from a TPDO that may predate the fault."""
    for code in (0x4310, 0x2310, 0x3210):
        driver.enable()
        responder.raise_fault(code, 0x03, b"now")
        with pytest.raises(DeviceFault, match=f"0x{code:04X}|statusword shows FAULT"):
            driver.check_health(synchronise=True)
        assert driver.fault_reset() == "SWITCH ON DISABLED" == responder.state
        driver.check_health(synchronise=True)


def test_detects_heartbeat_loss_at_the_consumer_time(driver, responder):
    timeout_s, period_s = driver.heartbeat_timeout_s, driver.producer_heartbeat_ms / 1000
    driver.check_health()
    responder.stop_heartbeat()
    stopped = time.monotonic()
    detected, message = poll_until_heartbeat_lost(driver)
    # the last heartbeat came at most one period before the stop
    assert timeout_s - period_s <= detected - stopped <= timeout_s + period_s + POLL_SLACK_S
    stated_s = float(re.search(r"for (\d+\.\d+) s", message).group(1))
    assert timeout_s <= stated_s <= timeout_s + period_s + POLL_SLACK_S
