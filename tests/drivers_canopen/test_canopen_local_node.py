"""Unit tests of the fixed LocalNode (no bus): write phases, limits, stored values."""

from __future__ import annotations

import pytest
from canopen import LocalNode
from canopen.sdo import SdoAbortedError

from ripple_hil_drivers.canopen_eds import load_dictionary
from ripple_hil_drivers.simulated.can_node import DriveLocalNode


def make_node(validate=None, after=None):
    calls = []

    def validate_and_apply(index, subindex, od, data):
        calls.append(("validate", index, node.stored_value(index, subindex)))
        if validate:
            validate(index, subindex, od, data)

    def after_store(index, subindex, od, data):
        calls.append(("after", index, node.stored_value(index, subindex)))

    node = DriveLocalNode(5, load_dictionary(node_id=5), validate_and_apply=validate_and_apply,
                          after_store=after_store, on_nmt_reset=lambda c: None,
                          on_nmt_state=lambda s: None)
    return node, calls


def test_after_store_sees_the_new_value_validate_sees_the_old():
    node, calls = make_node()
    node.set_data(0x1A01, 0, bytes([2]), check_writable=True)
    assert calls == [("validate", 0x1A01, 1), ("after", 0x1A01, 2)]


def test_plain_canopen_local_node_runs_callbacks_before_storing():
    # the canopen 2.4.x behaviour DriveLocalNode exists to fix
    node = LocalNode(5, load_dictionary(node_id=5))
    seen = []
    node.add_write_callback(lambda index, subindex, od, data: seen.append(
        node.data_store.get(index, {}).get(subindex)))
    node.set_data(0x1A01, 0, bytes([2]))
    assert seen == [None]


def test_rejected_write_stores_nothing():
    def refuse(index, subindex, od, data):
        raise SdoAbortedError(0x06090030)
    node, calls = make_node(validate=refuse)
    with pytest.raises(SdoAbortedError):
        node.set_data(0x2005, 0, (100).to_bytes(2, "little"), check_writable=True)
    assert node.stored_value(0x2005) == 1
    assert [c[0] for c in calls] == ["validate"]


@pytest.mark.parametrize("index, value, size, code", [
    (0x2005, 1801, 2, 0x06090031),   # encoder_decimation above 1800
    (0x2005, 0, 2, 0x06090032),      # below 1
    (0x6071, 1001, 2, 0x06090031),   # target torque above 1000 per mille
    (0x6041, 0, 2, 0x06010002),      # statusword is read-only
    (0x2005, 5, 4, 0x06070010),      # wrong length for UNSIGNED16
])
def test_limits_access_and_length_are_checked(index, value, size, code):
    node, _ = make_node()
    with pytest.raises(SdoAbortedError) as info:
        node.set_data(index, 0, value.to_bytes(size, "little", signed=True), check_writable=True)
    assert info.value.code == code
