"""Integration: master-loss detection between the Cia402Drive master and the simulated drive.

The master produces its own heartbeat and makes the drive consume it (0x1016); when the master
goes silent the drive sends EMCY 0x8130, performs the abort connection option 0x6007 and puts
every injection back to its default. Real canopen / python-can stacks on a ``virtual`` bus.
"""

from __future__ import annotations

import struct
import threading
import time

import can
import canopen
import pytest

from ripple_hil_drivers import canopen_402 as sm
from ripple_hil_drivers.canopen_eds import injection_objects, load_dictionary
from ripple_hil_drivers.cia402 import Cia402Drive
from ripple_hil_drivers.errors import DeviceFault, InjectionRangeError
from ripple_hil_drivers.simulated.can_heartbeat import ConsumerEntry
from hil.errors import InputError
from canopen_helpers import eventually as wait_until

pytestmark = [pytest.mark.integration, pytest.mark.timeout(30)]

NODE = 5
MASTER = 0x7F
EMCY_COB = 0x080 + NODE
INJECTED = {"ia_offset_a": 0.5, "dead_time_s": 2e-6, "encoder_decimation": 100}


def eventually(predicate, timeout_s=3.0):
    """``canopen_helpers.eventually`` with this file's longer default (master-loss actions)."""
    return wait_until(predicate, timeout_s)


def crash(master: Cia402Drive) -> None:
    """The master's process dies: its bus goes away without the clean-close path."""
    master.network.disconnect()


def frames(bus, can_id, timeout_s):
    """Every frame with ``can_id`` received within ``timeout_s``."""
    found, deadline = [], time.monotonic() + timeout_s
    while (remaining := deadline - time.monotonic()) > 0:
        msg = bus.recv(timeout=remaining)
        if msg is not None and msg.arbitration_id == can_id:
            found.append(msg)
    return found


def emcy_codes(bus, timeout_s):
    return [struct.unpack_from("<HB", m.data) for m in frames(bus, EMCY_COB, timeout_s)]


def raw_sdo_reader(bus_settings):
    """A canopen network with the drive as a plain RemoteNode: SDO uploads only, no NMT."""
    network = canopen.Network(can.Bus(interface="virtual", channel=bus_settings.channel))
    network.connect()
    node = network.add_node(NODE, load_dictionary(None, NODE))
    node.sdo.RESPONSE_TIMEOUT = 1.0
    return network, node


def test_the_drive_consumes_the_masters_heartbeat(drive, sim_drive, bus_settings):
    expected = MASTER << 16 | 500
    assert drive.consumer_heartbeat_entry == expected
    assert drive.sdo_read(0x1016, 1) == expected
    assert sim_drive.heartbeat_consumer.entries == [ConsumerEntry(producer_id=MASTER, time_ms=500)]
    with can.Bus(interface="virtual", channel=bus_settings.channel) as spy:
        beats = frames(spy, 0x700 + MASTER, 0.6)
    assert len(beats) >= 3
    assert all(bytes(m.data) == b"\x05" for m in beats)  # NMT state OPERATIONAL
    periods = [b.timestamp - a.timestamp for a, b in zip(beats, beats[1:])]
    assert max(periods) < 0.5  # well below the consumer time (period 125 ms + load jitter)


def test_a_crashed_master_leaves_the_drive_disabled_with_defaults(drive, sim_drive, twin,
                                                                   bus_settings):
    drive.enable()
    drive.set_injection(**INJECTED)
    assert twin.enabled and twin.injection.encoder_decimation == 100
    with can.Bus(interface="virtual", channel=bus_settings.channel) as spy:
        crash(drive)
        assert sim_drive.state == sm.OPERATION_ENABLED  # not before the consumer time
        assert eventually(lambda: sim_drive.state == sm.SWITCH_ON_DISABLED)
        assert (0x8130, 0x11) in emcy_codes(spy, 0.2)  # heartbeat error, comm. bit
    assert eventually(lambda: not twin.enabled)
    assert eventually(lambda: twin.injection == type(twin.injection)())
    assert sim_drive.master_lost

    defaults = {knob: obj.default_si for knob, obj in injection_objects().items()}
    with Cia402Drive(bus_settings, node_id=NODE, heartbeat_timeout_s=0.5) as again:
        assert again.state == sm.SWITCH_ON_DISABLED
        assert again.injection() == defaults
        assert eventually(lambda: not sim_drive.master_lost)  # our heartbeat re-armed it
        assert again.sdo_read(0x603F) == 0  # error code cleared by EMCY 0x0000
        again.enable()
        assert twin.enabled
        again.disable()


def test_statusword_changes_at_once_while_a_capture_holds_the_twin(drive, sim_drive, twin,
                                                                  bus_settings):
    drive.enable()
    drive.set_injection(**INJECTED)
    capture_running, capture_done = threading.Event(), threading.Event()

    def long_capture():
        with twin.lock:
            capture_running.set()
            capture_done.wait(10)

    capture = threading.Thread(target=long_capture, daemon=True)
    capture.start()
    assert capture_running.wait(2)
    network, node = raw_sdo_reader(bus_settings)
    try:
        crash(drive)
        assert eventually(lambda: sm.state_from_statusword(node.sdo[0x6041].raw)
                          == sm.SWITCH_ON_DISABLED)
        decimation = injection_objects()["encoder_decimation"]
        assert node.sdo[decimation.index].raw == decimation.default_count
        assert capture.is_alive()  # the twin is still busy: its action is pending
    finally:
        capture_done.set()
        capture.join(5)
        network.disconnect()
    assert eventually(lambda: not twin.enabled)
    assert twin.injection == type(twin.injection)()


def test_a_silent_master_is_told_by_emcy(drive, sim_drive, twin):
    drive.enable()
    drive._master_heartbeat.stop()  # the process lives on, its heartbeat thread does not
    assert eventually(lambda: drive.last_emcy is not None)
    assert drive.last_emcy.code == 0x8130
    with pytest.raises(DeviceFault, match="0x8130"):
        drive.check_health()
    # the EMCY goes out as the drive takes its abort action; the statusword TPDO follows it
    assert eventually(lambda: drive.state == sm.SWITCH_ON_DISABLED)
    assert eventually(lambda: not twin.enabled)


def test_clean_close_leaves_the_drive_as_the_bench_left_it(drive, sim_drive, twin, bus_settings):
    drive.enable()
    drive.set_injection(ia_offset_a=0.5)
    with can.Bus(interface="virtual", channel=bus_settings.channel) as spy:
        drive.close()
        assert sim_drive.heartbeat_consumer.entries == []
        assert emcy_codes(spy, 3 * drive.heartbeat_timeout_s) == []
    assert sim_drive.state == sm.OPERATION_ENABLED and not sim_drive.master_lost
    assert twin.enabled and twin.injection.ia_offset_a == 0.5


@pytest.mark.parametrize("option, expected", [(0, sm.OPERATION_ENABLED), (1, sm.FAULT),
                                              (3, sm.QUICK_STOP_ACTIVE)])
def test_abort_connection_option_code(drive, sim_drive, twin, option, expected):
    drive.sdo_write(0x6007, 0, option)
    drive.enable()
    drive.set_injection(**INJECTED)
    crash(drive)
    assert eventually(lambda: sim_drive.state == expected), sim_drive.state
    assert eventually(lambda: twin.injection == type(twin.injection)())  # whatever 0x6007 says
    assert twin.enabled == (expected == sm.OPERATION_ENABLED)


def test_abort_connection_option_code_range(drive):
    assert drive.sdo_read(0x6007) == 2  # default: disable voltage
    with pytest.raises(InjectionRangeError):
        drive.sdo_write(0x6007, 0, 4)


def test_monitoring_starts_at_the_first_heartbeat(sim_drive, bus_settings):
    """CiA 301: a configured consumer does not time out before it has seen its producer."""
    producer = 0x20
    with can.Bus(interface="virtual", channel=bus_settings.channel) as bus:
        request = struct.pack("<BHBI", 0x23, 0x1016, 1, producer << 16 | 200)
        bus.send(can.Message(arbitration_id=0x600 + NODE, data=request, is_extended_id=False))
        answer = frames(bus, 0x580 + NODE, 0.3)
        assert answer and answer[0].data[0] == 0x60  # download confirmed
        assert emcy_codes(bus, 0.6) == []  # three consumer times without a first heartbeat
        bus.send(can.Message(arbitration_id=0x700 + producer, data=b"\x05", is_extended_id=False))
        assert emcy_codes(bus, 0.6) == [(0x8130, 0x11)]  # one EMCY per loss
        bus.send(can.Message(arbitration_id=0x700 + producer, data=b"\x05", is_extended_id=False))
        assert emcy_codes(bus, 0.1) == [(0x0000, 0x00)]  # back: error reset


def test_master_node_id_is_checked(bus_settings):
    with pytest.raises(InputError, match="master_node_id"):
        Cia402Drive(bus_settings, node_id=5, master_node_id=5)
    with pytest.raises(InputError, match="master_node_id"):
        Cia402Drive(bus_settings, node_id=5, master_node_id=128)
