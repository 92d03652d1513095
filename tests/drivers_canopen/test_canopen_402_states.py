"""CiA 402 state machine tables (unit tests, no bus)."""

from __future__ import annotations

import pytest

from ripple_hil_drivers import canopen_402 as sm

ALL_STATES = [sm.NOT_READY, sm.SWITCH_ON_DISABLED, sm.READY_TO_SWITCH_ON, sm.SWITCHED_ON,
              sm.OPERATION_ENABLED, sm.QUICK_STOP_ACTIVE, sm.FAULT_REACTION_ACTIVE, sm.FAULT]


@pytest.mark.parametrize("state", ALL_STATES)
def test_statusword_decodes_to_its_state(state):
    assert sm.state_from_statusword(sm.statusword_for(state)) == state


@pytest.mark.parametrize("state, controlword, expected", [
    (sm.SWITCH_ON_DISABLED, sm.CW_SHUTDOWN, sm.READY_TO_SWITCH_ON),          # 2
    (sm.READY_TO_SWITCH_ON, sm.CW_SWITCH_ON, sm.SWITCHED_ON),                # 3
    (sm.SWITCHED_ON, sm.CW_ENABLE_OPERATION, sm.OPERATION_ENABLED),          # 4
    (sm.OPERATION_ENABLED, sm.CW_SWITCH_ON, sm.SWITCHED_ON),                 # 5
    (sm.SWITCHED_ON, sm.CW_SHUTDOWN, sm.READY_TO_SWITCH_ON),                 # 6
    (sm.READY_TO_SWITCH_ON, sm.CW_DISABLE_VOLTAGE, sm.SWITCH_ON_DISABLED),   # 7
    (sm.READY_TO_SWITCH_ON, sm.CW_QUICK_STOP, sm.SWITCH_ON_DISABLED),        # 7
    (sm.OPERATION_ENABLED, sm.CW_SHUTDOWN, sm.READY_TO_SWITCH_ON),           # 8
    (sm.OPERATION_ENABLED, sm.CW_DISABLE_VOLTAGE, sm.SWITCH_ON_DISABLED),    # 9
    (sm.SWITCHED_ON, sm.CW_DISABLE_VOLTAGE, sm.SWITCH_ON_DISABLED),          # 10
    (sm.OPERATION_ENABLED, sm.CW_QUICK_STOP, sm.QUICK_STOP_ACTIVE),          # 11
    (sm.QUICK_STOP_ACTIVE, sm.CW_DISABLE_VOLTAGE, sm.SWITCH_ON_DISABLED),    # 12
    (sm.QUICK_STOP_ACTIVE, sm.CW_ENABLE_OPERATION, sm.OPERATION_ENABLED),    # 16
    (sm.SWITCH_ON_DISABLED, sm.CW_ENABLE_OPERATION, sm.SWITCH_ON_DISABLED),  # not allowed
    (sm.READY_TO_SWITCH_ON, sm.CW_ENABLE_OPERATION, sm.OPERATION_ENABLED),   # 3 + 4
    (sm.SWITCH_ON_DISABLED, sm.CW_SWITCH_ON, sm.SWITCH_ON_DISABLED),         # not allowed
    (sm.FAULT, sm.CW_SHUTDOWN, sm.FAULT),                                    # only reset leaves
])
def test_device_transitions(state, controlword, expected):
    assert sm.device_transition(state, controlword, 0) == expected


def test_fault_reset_needs_a_rising_edge_of_bit_7():
    assert sm.device_transition(sm.FAULT, sm.CW_FAULT_RESET, 0) == sm.SWITCH_ON_DISABLED  # 15
    assert sm.device_transition(sm.FAULT, sm.CW_FAULT_RESET, sm.CW_FAULT_RESET) == sm.FAULT
    assert sm.device_transition(sm.OPERATION_ENABLED, sm.CW_FAULT_RESET, 0) == sm.OPERATION_ENABLED


def test_mode_names_map_to_cia402_codes():
    assert sm.MODE_CODES["cyclic_synchronous_torque"] == 10
    assert sm.MODE_CODES["profile_torque"] == 4
    assert sm.MODE_CODES["profile_velocity"] == 3
    assert sm.supported_mode_bit(10) == 0x200
