"""Every CiA 402 device-control command in every state, on the simulated drive over the bus.

The expected table (``cia402_table``) is written out from the CiA 402-2 command table,
independently of ``ripple_hil_drivers.canopen_402.device_transition``. Each case brings the drive to
its start state with controlword writes, sends the command by SDO (applied before the SDO answer)
and reads the statusword back by SDO.
"""

from __future__ import annotations

import pytest

from ripple_hil_drivers import canopen_402 as sm

pytestmark = [pytest.mark.integration, pytest.mark.timeout(60)]

from cia402_table import (ALLOWED, COMMANDS, DISABLE_VOLTAGE, FAULT, FAULT_RESET, OE, QSA,
                          QUICK_STOP, RTSO, SHUTDOWN, SO, SOD, SWITCH_ON, SWITCH_ON_ENABLE)

PATH_FROM_SOD = {SOD: (), RTSO: (SHUTDOWN,), SO: (SHUTDOWN, SWITCH_ON),
                 OE: (SHUTDOWN, SWITCH_ON, SWITCH_ON_ENABLE),
                 QSA: (SHUTDOWN, SWITCH_ON, SWITCH_ON_ENABLE, QUICK_STOP)}


def state_now(drive) -> str:
    return sm.state_from_statusword(drive.sdo_read(0x6041))


def bring_to(drive, sim_drive, state) -> None:
    """From wherever the drive is, back to SWITCH ON DISABLED, then along the path to ``state``."""
    if state_now(drive) == FAULT:
        drive.sdo_write(0x6040, 0, DISABLE_VOLTAGE)
        drive.sdo_write(0x6040, 0, FAULT_RESET)
    drive.sdo_write(0x6040, 0, DISABLE_VOLTAGE)
    assert state_now(drive) == SOD
    if state == FAULT:
        sim_drive.raise_fault(code=0x5000, text="table")
    for command in PATH_FROM_SOD.get(state, ()):
        drive.sdo_write(0x6040, 0, command)
    assert state_now(drive) == state


def test_every_command_in_every_state(drive, sim_drive, twin):
    outcomes = {}
    for start, allowed in ALLOWED.items():
        for command in COMMANDS:
            bring_to(drive, sim_drive, start)
            drive.sdo_write(0x6040, 0, command)
            outcomes[(start, command)] = (state_now(drive), twin.enabled)
    expected = {**ALLOWED, FAULT: {FAULT_RESET: SOD}}                  # 15 (rising edge)
    wrong = {(start, f"0x{command:04X}"): got for (start, command), (got, _) in outcomes.items()
             if got != expected[start].get(command, start)}
    assert wrong == {}, f"state after command differs from CiA 402: {wrong}"
    # the power stage follows the state: on exactly in OPERATION ENABLED
    assert all(enabled == (state == OE) for state, enabled in outcomes.values())
    refused = sum(command not in expected[start] for start, command in outcomes)
    assert refused == len(outcomes) - sum(len(row) for row in expected.values()) > 20


def test_fault_reset_acts_on_the_rising_edge_only(drive, sim_drive):
    bring_to(drive, sim_drive, FAULT)
    drive.sdo_write(0x6040, 0, FAULT_RESET)
    assert state_now(drive) == SOD
    bring_to(drive, sim_drive, FAULT)          # bit 7 was cleared on the way
    drive.sdo_write(0x6040, 0, FAULT_RESET)    # rising edge: reset
    sim_drive.raise_fault(code=0x5000, text="again")
    drive.sdo_write(0x6040, 0, FAULT_RESET)    # bit 7 held high: no new edge
    assert state_now(drive) == FAULT


def test_driver_enable_from_ready_to_switch_on_uses_the_standard_path(drive, twin):
    drive.sdo_write(0x6040, 0, SHUTDOWN)
    drive.enable()
    assert drive.state == OE and twin.enabled
