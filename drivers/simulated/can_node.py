"""A canopen ``LocalNode`` with the canopen 2.4.x slave-side pitfalls fixed.

* Write hooks run in two phases: ``validate_and_apply`` before the value is stored (it may raise
  ``SdoAbortedError`` so nothing is stored), ``after_store`` once the data store holds the new
  value (canopen runs its write callbacks before storing, so a callback cannot re-read it).
* Every object with LowLimit/HighLimit in the EDS is range-checked on write (SDO abort
  0x06090031 value too high / 0x06090032 too low); canopen stores any value.
* SDO requests are ignored while NMT-STOPPED (CiA 301: only NMT and heartbeat then); canopen
  answers them.
* NMT "reset node" / "reset communication" send the boot-up message and return to
  PRE-OPERATIONAL (canopen stays in INITIALISING and sends nothing).
* PDOs are handled by ``ripple_hil_drivers.simulated.can_pdo`` (canopen's LocalNode neither applies RPDOs
  nor sends TPDOs, and ignores a master's remap).
"""

from __future__ import annotations

import logging
import struct
from typing import Callable

from canopen import LocalNode
from canopen import objectdictionary
from canopen.sdo import SdoAbortedError

logger = logging.getLogger(__name__)

ABORT_VALUE_RANGE = 0x06090030
ABORT_VALUE_TOO_HIGH = 0x06090031
ABORT_VALUE_TOO_LOW = 0x06090032
ABORT_WRONG_LENGTH = 0x06070010
ABORT_READ_ONLY = 0x06010002
ABORT_CANNOT_STORE = 0x08000020
ABORT_DEVICE_STATE = 0x08000022

NMT_RESET_COMMANDS = (0x81, 0x82)

WriteHook = Callable[[int, int, object, bytes], None]


class DriveLocalNode(LocalNode):
    """LocalNode with two-phase write hooks, limit checks and CiA 301 NMT behaviour."""

    def __init__(self, node_id: int, object_dictionary, *,
                 validate_and_apply: WriteHook, after_store: WriteHook,
                 on_nmt_reset: Callable[[int], None], on_nmt_state: Callable[[str], None]):
        super().__init__(node_id, object_dictionary)
        # canopen registered NmtSlave.on_write (0x1017) as a pre-store callback; the drive node
        # handles 0x1017 in after_store instead, so heartbeat changes see the stored value.
        self._write_callbacks.clear()
        self._validate_and_apply = validate_and_apply
        self._after_store = after_store
        self._on_nmt_reset = on_nmt_reset
        self._on_nmt_state = on_nmt_state

    # -- network wiring: SDO gated by NMT state, NMT reset handled ---------------------------
    def associate_network(self, network) -> None:
        super().associate_network(network)
        network.unsubscribe(self.sdo.rx_cobid, self.sdo.on_request)
        network.unsubscribe(0, self.nmt.on_command)
        network.subscribe(self.sdo.rx_cobid, self._on_sdo_request)
        network.subscribe(0, self._on_nmt_command)

    def remove_network(self) -> None:
        if not self.has_network():
            return
        self.network.unsubscribe(self.sdo.rx_cobid, self._on_sdo_request)
        self.network.unsubscribe(0, self._on_nmt_command)
        self.network.subscribe(self.sdo.rx_cobid, self.sdo.on_request)
        self.network.subscribe(0, self.nmt.on_command)
        super().remove_network()

    def _on_sdo_request(self, can_id: int, data: bytes, timestamp: float) -> None:
        if self.nmt.state == "STOPPED":
            return
        self.sdo.on_request(can_id, data, timestamp)

    def _on_nmt_command(self, can_id: int, data: bytes, timestamp: float) -> None:
        if len(data) < 2:
            return
        command, node_id = struct.unpack_from("BB", data)
        if node_id not in (0, self.id):
            return
        if command in NMT_RESET_COMMANDS:
            self._on_nmt_reset(command)
            self.nmt.send_command(command)  # INITIALISING: sends the boot-up message
            self.nmt.send_command(0x80)     # then PRE-OPERATIONAL, heartbeat from 0x1017
        else:
            self.nmt.on_command(can_id, data, timestamp)
        self._on_nmt_state(self.nmt.state)

    # -- object access ----------------------------------------------------------------------
    def set_data(self, index: int, subindex: int, data: bytes, check_writable: bool = False) -> None:
        obj = self._find_object(index, subindex)
        if check_writable and not obj.writable:
            raise SdoAbortedError(ABORT_READ_ONLY)
        if obj.data_type in objectdictionary.NUMBER_TYPES and 8 * len(data) != len(obj):
            raise SdoAbortedError(ABORT_WRONG_LENGTH)
        if obj.data_type in objectdictionary.NUMBER_TYPES:
            value = obj.decode_raw(data)
            if obj.max is not None and value > obj.max:
                raise SdoAbortedError(ABORT_VALUE_TOO_HIGH)
            if obj.min is not None and value < obj.min:
                raise SdoAbortedError(ABORT_VALUE_TOO_LOW)
        self._validate_and_apply(index, subindex, obj, bytes(data))
        self.data_store.setdefault(index, {})[subindex] = bytes(data)
        self._after_store(index, subindex, obj, bytes(data))

    def find_object(self, index: int, subindex: int = 0):
        """The dictionary entry; SdoAbortedError (0x06020000 / 0x06090011) if there is none."""
        return self._find_object(index, subindex)

    def stored_value(self, index: int, subindex: int = 0):
        """Decoded value from the data store (or the EDS default), bypassing read callbacks."""
        obj = self.find_object(index, subindex)
        try:
            return obj.decode_raw(self.data_store[index][subindex])
        except KeyError:
            return obj.value if obj.value is not None else obj.default
