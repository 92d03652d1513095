"""Every CiA 402 device-control command in every state, on the simulated drive over the bus.

The expected table is written out here from the CiA 402-2 command table (bits 7, 3..0:
shutdown 0xxx x110 -> 2, 6, 8; switch on 0xxx 0111 -> 3; switch on + enable operation
0xxx 1111 -> 3 + 4; disable voltage 0xxx xx0x -> 7, 9, 10, 12; quick stop 0xxx x01x -> 7, 10, 11;
disable operation 0xxx 0111 -> 5; enable operation 0xxx 1111 -> 4, 16; fault reset: bit 7 rising
-> 15), independently of ``drivers.canopen_402.device_transition``. Each case brings the drive to
its start state with controlword writes, sends the command by SDO (applied before the SDO answer)
and reads the statusword back by SDO.
"""

from __future__ import annotations

import pytest

from drivers import canopen_402 as sm

pytestmark = [pytest.mark.integration, pytest.mark.timeout(60)]

SOD, RTSO, SO, OE, QSA, FAULT = (sm.SWITCH_ON_DISABLED, sm.READY_TO_SWITCH_ON, sm.SWITCHED_ON,
                                 sm.OPERATION_ENABLED, sm.QUICK_STOP_ACTIVE, sm.FAULT)

# Command words, with bit patterns that differ only in "x" (irrelevant) bits of the table.
SHUTDOWN, SHUTDOWN_X = 0x0006, 0x000E
SWITCH_ON = 0x0007
SWITCH_ON_ENABLE = 0x000F
DISABLE_VOLTAGE, DISABLE_VOLTAGE_X = 0x0000, 0x000D
QUICK_STOP, QUICK_STOP_X = 0x0002, 0x000B
FAULT_RESET = 0x0080
COMMANDS = (SHUTDOWN, SHUTDOWN_X, SWITCH_ON, SWITCH_ON_ENABLE, DISABLE_VOLTAGE,
            DISABLE_VOLTAGE_X, QUICK_STOP, QUICK_STOP_X, FAULT_RESET)

# state -> {command -> state after}; a command missing from a row is refused (state unchanged).
ALLOWED = {
    SOD: {SHUTDOWN: RTSO, SHUTDOWN_X: RTSO},                                         # 2
    RTSO: {SWITCH_ON: SO, SWITCH_ON_ENABLE: OE,                                       # 3, 3+4
           DISABLE_VOLTAGE: SOD, DISABLE_VOLTAGE_X: SOD, QUICK_STOP: SOD, QUICK_STOP_X: SOD},  # 7
    SO: {SWITCH_ON_ENABLE: OE, SHUTDOWN: RTSO, SHUTDOWN_X: RTSO,                      # 4, 6
         DISABLE_VOLTAGE: SOD, DISABLE_VOLTAGE_X: SOD, QUICK_STOP: SOD, QUICK_STOP_X: SOD},  # 10
    OE: {SWITCH_ON: SO, SHUTDOWN: RTSO, SHUTDOWN_X: RTSO,                             # 5, 8
         DISABLE_VOLTAGE: SOD, DISABLE_VOLTAGE_X: SOD,                                # 9
         QUICK_STOP: QSA, QUICK_STOP_X: QSA},                                          # 11
    QSA: {DISABLE_VOLTAGE: SOD, DISABLE_VOLTAGE_X: SOD, SWITCH_ON_ENABLE: OE},        # 12, 16
    FAULT: {FAULT_RESET: SOD},                                                         # 15
}
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
    wrong = {(start, f"0x{command:04X}"): got for (start, command), (got, _) in outcomes.items()
             if got != ALLOWED[start].get(command, start)}
    assert wrong == {}, f"state after command differs from CiA 402: {wrong}"
    # the power stage follows the state: on exactly in OPERATION ENABLED
    assert all(enabled == (state == OE) for state, enabled in outcomes.values())
    refused = sum(command not in ALLOWED[start] for start, command in outcomes)
    assert refused == len(outcomes) - sum(len(row) for row in ALLOWED.values()) > 20


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
