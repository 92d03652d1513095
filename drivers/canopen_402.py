"""The CiA 402 power state machine: statusword decoding, controlword commands, device transitions.

Shared by the master-side driver (``drivers.cia402``) and the simulated drive node. State names
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
    """The drive-side state after receiving ``controlword`` in ``state`` (CiA 402 transitions).

    Fault reset acts on the rising edge of bit 7 only. Commands not allowed in a state leave it
    unchanged. Transition numbers follow CiA 402-2 figure "state machine".
    """
    if state in (FAULT, FAULT_REACTION_ACTIVE):
        rising_reset = controlword & 0x80 and not previous_controlword & 0x80
        return SWITCH_ON_DISABLED if state == FAULT and rising_reset else state  # 15
    if controlword & 0x80:
        return state  # fault reset outside FAULT: no effect
    enable_voltage = controlword & 0x02
    quick_stop_inactive = controlword & 0x04
    if not enable_voltage:
        return SWITCH_ON_DISABLED if state != NOT_READY else state  # 7, 9, 10, 12
    if not quick_stop_inactive:  # quick stop command x01x
        if state == OPERATION_ENABLED:
            return QUICK_STOP_ACTIVE  # 11
        if state in (READY_TO_SWITCH_ON, SWITCHED_ON):
            return SWITCH_ON_DISABLED  # 7, 10
        return state
    low = controlword & 0x0F
    if low & 0x01 == 0:  # shutdown xx110
        if state in (SWITCH_ON_DISABLED, SWITCHED_ON, OPERATION_ENABLED):
            return READY_TO_SWITCH_ON  # 2, 6, 8
        return state
    if low == CW_SWITCH_ON:
        if state == READY_TO_SWITCH_ON:
            return SWITCHED_ON  # 3
        if state == OPERATION_ENABLED:
            return SWITCHED_ON  # 5
        return state
    if low == CW_ENABLE_OPERATION:
        if state == SWITCHED_ON:
            return OPERATION_ENABLED  # 4
        if state == READY_TO_SWITCH_ON:
            return SWITCHED_ON  # 3 (enable operation implies switch on first)
        if state == QUICK_STOP_ACTIVE:
            return OPERATION_ENABLED  # 16
    return state
