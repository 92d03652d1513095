"""The CiA 402 power state machine: statusword decoding, controlword commands, device transitions.

Shared by the master-side driver (``ripple_hil_drivers.cia402``) and the simulated drive node. State names
are canopen's (``canopen.profiles.p402.State402``), e.g. "OPERATION ENABLED".
"""

from __future__ import annotations

from canopen.profiles.p402 import OperationMode, State402

NOT_READY = "NOT READY TO SWITCH ON"
SWITCH_ON_DISABLED = "SWITCH ON DISABLED"
READY_TO_SWITCH_ON = "READY TO SWITCH ON"
SWITCHED_ON = "SWITCHED ON"
OPERATION_ENABLED = "OPERATION ENABLED"
QUICK_STOP_ACTIVE = "QUICK STOP ACTIVE"
FAULT_REACTION_ACTIVE = "FAULT REACTION ACTIVE"
FAULT = "FAULT"

# Controlword commands (CiA 402 table "device control commands"), bits 0..3 and 7.
CW_SHUTDOWN = 0x0006
CW_SWITCH_ON = 0x0007
CW_ENABLE_OPERATION = 0x000F
CW_DISABLE_VOLTAGE = 0x0000
CW_QUICK_STOP = 0x0002
CW_FAULT_RESET = 0x0080

# Statusword as produced by the simulated drive in each state (bit 4 voltage enabled, bit 5
# quick stop NOT active, bit 9 remote).
_SW_REMOTE = 0x0200
STATUSWORD_OF_STATE = {
    NOT_READY: 0x0000,
    SWITCH_ON_DISABLED: 0x0040,
    READY_TO_SWITCH_ON: 0x0031,
    SWITCHED_ON: 0x0033,
    OPERATION_ENABLED: 0x0037,
    QUICK_STOP_ACTIVE: 0x0017,
    FAULT_REACTION_ACTIVE: 0x001F,
    FAULT: 0x0018,
}

MODE_CODES = {
    "profile_velocity": OperationMode.PROFILED_VELOCITY,
    "profile_torque": OperationMode.PROFILED_TORQUE,
    "cyclic_synchronous_velocity": OperationMode.CYCLIC_SYNCHRONOUS_VELOCITY,
    "cyclic_synchronous_torque": OperationMode.CYCLIC_SYNCHRONOUS_TORQUE,
    "profile_position": OperationMode.PROFILED_POSITION,
    "cyclic_synchronous_position": OperationMode.CYCLIC_SYNCHRONOUS_POSITION,
}
"""Mode names the driver accepts, to their 0x6060 codes."""


def supported_mode_bit(code: int) -> int:
    """Bit of object 0x6502 (supported drive modes) that advertises mode ``code``."""
    return OperationMode.SUPPORTED[OperationMode.CODE2NAME[code]]


def statusword_for(state: str) -> int:
    return STATUSWORD_OF_STATE[state] | _SW_REMOTE


def state_from_statusword(statusword: int) -> str:
    """Decode a statusword (0x6041) into the CiA 402 state name, or "UNKNOWN"."""
    for state, (mask, bits) in State402.SW_MASK.items():
        if statusword & mask == bits:
            return state
    return "UNKNOWN"


def device_transition(state: str, controlword: int, previous_controlword: int) -> str:
    """The drive-side state after receiving ``controlword`` in ``state`` (CiA 402-2 state machine).

    Device control commands (bits 7, 3..0; x = irrelevant) and the transitions they trigger:
    shutdown 0xxx x110 (2, 6, 8); switch on 0xxx 0111 (3); switch on + enable operation
    0xxx 1111 (3 + 4: from READY TO SWITCH ON straight to OPERATION ENABLED); disable voltage
    0xxx xx0x (7, 9, 10, 12); quick stop 0xxx x01x (7, 10, 11); disable operation 0xxx 0111 (5);
    enable operation 0xxx 1111 (4, 16); fault reset: rising edge of bit 7 (15). A command not
    allowed in a state (e.g. 0x000F in SWITCH ON DISABLED, which needs shutdown first) leaves the
    state unchanged; so does bit 7 outside FAULT. The automatic transitions (0, 1, 13, 14) are
    not commands. QUICK STOP ACTIVE stays until disable voltage (12) or enable operation (16),
    i.e. quick stop option codes 5..8 (no automatic 12 after the stop).
    """
    if state == FAULT:
        rising_reset = controlword & 0x80 and not previous_controlword & 0x80
        return SWITCH_ON_DISABLED if rising_reset else state  # 15
    if state in (FAULT_REACTION_ACTIVE, NOT_READY) or controlword & 0x80:
        return state
    switch_on, enable_voltage = controlword & 0x01, controlword & 0x02
    quick_stop_inactive, enable_operation = controlword & 0x04, controlword & 0x08
    if not enable_voltage:                                       # disable voltage
        return SWITCH_ON_DISABLED                                # 7, 9, 10, 12
    if not quick_stop_inactive:                                  # quick stop
        if state == OPERATION_ENABLED:
            return QUICK_STOP_ACTIVE                             # 11
        return SWITCH_ON_DISABLED if state in (READY_TO_SWITCH_ON, SWITCHED_ON) else state  # 7, 10
    if not switch_on:                                            # shutdown
        if state in (SWITCH_ON_DISABLED, SWITCHED_ON, OPERATION_ENABLED):
            return READY_TO_SWITCH_ON                            # 2, 6, 8
        return state
    if not enable_operation:                                     # switch on / disable operation
        return SWITCHED_ON if state in (READY_TO_SWITCH_ON, OPERATION_ENABLED) else state  # 3, 5
    if state in (READY_TO_SWITCH_ON, SWITCHED_ON, QUICK_STOP_ACTIVE):   # switch on + enable op.
        return OPERATION_ENABLED                                 # 3 + 4, 4, 16
    return state
