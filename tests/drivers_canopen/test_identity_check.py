"""The drive's identity is checked before anything is written to it (issue 32 item 2): a
``Cia402Drive.identity_check`` that refuses leaves the simulated drive exactly as it was — no SDO
download (heartbeat, PDO mapping), no NMT command — and the configured identity is what the
driver reads over SDO."""

from __future__ import annotations

import pytest

from hil.dut import DutSerialRefused, dut_section


def test_a_refused_identity_sends_nothing_to_the_drive(twin, bus_settings):
    from ripple_hil_drivers.cia402 import Cia402Drive
    from ripple_hil_drivers.simulated.drive_node import SimulatedDrive

    sim = SimulatedDrive(twin, bus_settings, node_id=5,
                         identity={"vendor": 0x00ABCDEF, "product": 7, "revision": 3,
                                   "serial": 42})
    stored: list[int] = []
    states: list[str] = []
    sim._after_store = lambda index, *rest: stored.append(index)    # every SDO download
    sim._on_nmt_state = states.append                                # every NMT command
    sim.start()
    seen = {}

    def refuse(identity):
        seen.update(identity)
        dut_section("EPS-A-0043", "--dut-serial", identity, "EPS-A-{serial:04d}")

    drive = Cia402Drive(bus_settings, node_id=5, sdo_timeout_s=0.5, heartbeat_timeout_s=0.5)
    drive.identity_check = refuse
    try:
        with pytest.raises(DutSerialRefused, match="EPS-A-0042"):
            drive.connect()
    finally:
        drive.close()
        sim.stop()
    assert {k: seen[k] for k in ("vendor", "product", "revision", "serial")} == {
        "vendor": 0x00ABCDEF, "product": 7, "revision": 3, "serial": 42}
    assert stored == [] and states == []


def test_the_same_drive_is_driven_when_the_serial_matches(twin, bus_settings):
    from ripple_hil_drivers.cia402 import Cia402Drive
    from ripple_hil_drivers.simulated.drive_node import SimulatedDrive

    sim = SimulatedDrive(twin, bus_settings, node_id=5, identity={"serial": 42})
    stored: list[int] = []
    states: list[str] = []
    after_store, on_state = sim._after_store, sim._on_nmt_state
    sim._after_store = lambda index, *rest: (stored.append(index), after_store(index, *rest))
    sim._on_nmt_state = lambda state: (states.append(state), on_state(state))
    sim.start()
    sections = []
    drive = Cia402Drive(bus_settings, node_id=5, sdo_timeout_s=0.5, heartbeat_timeout_s=0.5)
    drive.identity_check = lambda identity: sections.append(
        dut_section("EPS-A-0042", "station scan", identity, "EPS-A-{serial:04d}"))
    try:
        drive.connect()
        assert drive.node.nmt.state == "OPERATIONAL"
    finally:
        drive.close()
        sim.stop()
    assert sections[0]["check"] == "match"
    # the spies of the refused case do see a connect's writes and NMT commands
    assert 0x1017 in stored and "OPERATIONAL" in states
