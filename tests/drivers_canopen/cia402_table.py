"""The CiA 402-2 device-control table written out for the tests, independent of the drivers.

Bits 7, 3..0 of the controlword (x = irrelevant): shutdown 0xxx x110 -> transitions 2, 6, 8;
switch on 0xxx 0111 -> 3; switch on + enable operation 0xxx 1111 -> 3 + 4; disable voltage
0xxx xx0x -> 7, 9, 10, 12; quick stop 0xxx x01x -> 7, 10, 11; disable operation 0xxx 0111 -> 5;
enable operation 0xxx 1111 -> 4, 16; fault reset: bit 7 rising -> 15. Statusword patterns
(bits 6, 5, 3..0): SWITCH ON DISABLED x1xx 0000, READY TO SWITCH ON x01x 0001, SWITCHED ON
x01x 0011, OPERATION ENABLED x01x 0111, QUICK STOP ACTIVE x00x 0111, FAULT x0xx 1000.
"""

from __future__ import annotations

SOD, RTSO, SO, OE, QSA, FAULT = ("SWITCH ON DISABLED", "READY TO SWITCH ON", "SWITCHED ON",
                                 "OPERATION ENABLED", "QUICK STOP ACTIVE", "FAULT")

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
    FAULT: {},                                                                         # 15: edge
}

STATUSWORD = {SOD: 0x0040, RTSO: 0x0021, SO: 0x0023, OE: 0x0027, QSA: 0x0007, FAULT: 0x0008}
REMOTE = 0x0200  # statusword bit 9


def command_of(controlword: int) -> str:
    """The table's command a controlword encodes (bits 7, 3..0 only)."""
    low = controlword & 0x0F
    if controlword & 0x80:
        return "fault reset"
    if not low & 0b0010:
        return "disable voltage"
    if low & 0b0110 == 0b0010:
        return "quick stop"
    if low & 0b0111 == 0b0110:
        return "shutdown"
    return "switch on" if low == 0b0111 else "enable operation"


TRANSITIONS = {
    (SOD, "shutdown"): RTSO, (RTSO, "switch on"): SO, (RTSO, "enable operation"): OE,
    (RTSO, "disable voltage"): SOD, (RTSO, "quick stop"): SOD, (SO, "enable operation"): OE,
    (SO, "shutdown"): RTSO, (SO, "disable voltage"): SOD, (SO, "quick stop"): SOD,
    (OE, "switch on"): SO, (OE, "shutdown"): RTSO, (OE, "disable voltage"): SOD,
    (OE, "quick stop"): QSA, (QSA, "disable voltage"): SOD, (QSA, "enable operation"): OE,
}


def next_state(state: str, controlword: int, previous_controlword: int) -> str:
    """The state after ``controlword`` per the table (fault reset on the rising edge of bit 7)."""
    if state == FAULT:
        return SOD if controlword & 0x80 and not previous_controlword & 0x80 else FAULT
    return TRANSITIONS.get((state, command_of(controlword)), state)
