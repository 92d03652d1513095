"""The simulated CiA 402 drive: a CANopen slave backed by one ``hil.sim.DriveTwin``.

Object dictionary: an EDS (default: the shipped ``drivers/data/ripple_drive.eds``); which of its
objects carry the injection knobs, the current command and the restore command: a drive profile
(``ripple_hil_drivers.drive_profile``; default: the shipped one). Behaviour:

* CiA 402 state machine driven by controlword writes (SDO or RPDO); entering OPERATION ENABLED
  calls ``twin.enable()``, leaving it (disable, quick stop, fault, NMT stop) ``twin.disable()``.
* Live objects are read from the twin: statusword, mode display, position actual (encoder
  counts), velocity actual (rpm), torque actual (per mille of 0x6076, from the twin's
  electromagnetic torque — a real drive reports its own current-based estimate), and every
  injection knob of the profile (shipped: 0x2001..) from ``twin.injection``, so a read-back
  proves the twin took it.
* Writes to injection objects go to ``twin.set_injection`` (out of range → SDO abort
  0x06090031/32 from the EDS limits, or 0x06090030 when the twin rejects the value); the
  profile's restore object (shipped: 0x2000 ← 0x64616F6C "load") calls
  ``twin.restore_defaults()``; 0x6071 target torque and the profile's current command (shipped:
  0x2100) set ``twin.current_command_a`` (torque / kt, kt from ``hil.motor``);
  0x60FF target velocity sets the dyno speed ``twin.speed_rpm`` (the simulated bench has one speed).
* TPDOs (statusword, actual values) are sent on change, on their event timer or on SYNC; RPDOs
  are applied to the dictionary; a master's PDO remap takes effect (see ``can_pdo``).
* Heartbeat producer from 0x1017; EMCY on ``raise_fault`` and on fault reset (code 0x0000), on
  the COB-ID in 0x1014 (bit 31 set: no EMCY); SYNC consumed on the COB-ID in 0x1005. Motor rated
  torque 0x6076 (rw) is read live for every per-mille conversion.
* Master-loss detection: a heartbeat consumer per 0x1016 entry (``can_heartbeat``). On a
  timeout the drive sends EMCY 0x8130 (heartbeat error), performs the abort connection option
  0x6007 (0 none, 1 fault, 2 disable voltage = default, 3 quick stop) and restores every
  injection to its default. The CiA 402 state (statusword) changes at once; the twin is told
  (``twin.disable()``, ``twin.restore_defaults()``) by a worker thread as soon as the twin's
  lock is free — a long DAQ capture may hold it. A real drive's gates go off at once; in the
  simulation the capture already running finishes with the old settings. Until the twin has
  taken the defaults, the injection objects read their defaults (the drive's parameters are
  already reset) and every object write first waits for the twin to take them. When the
  heartbeat comes back the drive sends EMCY 0x0000.
"""

from __future__ import annotations

import logging
import threading
import time

import canopen
from canopen.sdo import SdoAbortedError

from ripple_hil_drivers import canopen_402 as sm
from ripple_hil_drivers.canopen_eds import load_dictionary
from ripple_hil_drivers.canopen_transport import NOTIFIER_CYCLE_S, CanBusSettings, open_bus
from ripple_hil_drivers.drive_profile import load_profile
from ripple_hil_drivers.simulated.can_heartbeat import (CONSUMER_HEARTBEAT_INDEX, HeartbeatConsumer,
                                             check_consumer_write, consumer_entries)
from ripple_hil_drivers.simulated.can_node import ABORT_CANNOT_STORE, ABORT_VALUE_RANGE, DriveLocalNode
from ripple_hil_drivers.simulated.can_pdo import (COB_ID_SYNC_INDEX, PdoEngine, is_pdo_config_index,
                                      validate_mapping_entry)
from hil.motor import TABLE_I

logger = logging.getLogger(__name__)

_STATUS_CACHE_S = 0.001

COB_ID_EMCY_INDEX = 0x1014
EMCY_HEARTBEAT_ERROR = 0x8130  # CiA 301: life guard error or heartbeat error
ABORT_CONNECTION_OPTION_INDEX = 0x6007
ABORT_OPTION_NONE, ABORT_OPTION_FAULT, ABORT_OPTION_DISABLE_VOLTAGE, ABORT_OPTION_QUICK_STOP = 0, 1, 2, 3


class SwitchableEmcyProducer(canopen.emcy.EmcyProducer):
    """canopen's EMCY producer on the COB-ID of a 0x1014 entry; bit 31 set = EMCY not sent."""

    def __init__(self, entry: int) -> None:
        super().__init__(entry & 0x7FF)
        self.enabled = not entry & 0x80000000

    def set_entry(self, entry: int) -> None:
        self.cob_id, self.enabled = entry & 0x7FF, not entry & 0x80000000

    def send(self, code: int, register: int = 0, data: bytes = b"") -> None:
        if self.enabled:
            super().send(code, register, data)

    def reset(self, register: int = 0, data: bytes = b"") -> None:
        if self.enabled:
            super().reset(register, data)


def _gates_go_off(old_state: str, new_state: str) -> bool:
    """True if the transition old → new switches the power stage off."""
    return old_state == sm.OPERATION_ENABLED or new_state in (sm.FAULT, sm.QUICK_STOP_ACTIVE)


def _error_register_for(code: int) -> int:
    """Error register 0x1001 bits for an EMCY code (CiA 301: generic + class bit)."""
    class_bits = {0x2: 0x02, 0x3: 0x04, 0x4: 0x08, 0x8: 0x10}
    return 0x01 | class_bits.get(code >> 12, 0)


class SimulatedDrive:
    """CiA 402 drive node on a python-can bus, backed by a ``DriveTwin`` in simulated time."""

    def __init__(self, twin, settings: CanBusSettings, node_id: int = 5, *, eds_path=None,
                 serial_number: int = 0x00000001, torque_constant_nm_per_a: float | None = None,
                 profile=None, identity: dict | None = None,
                 software_version: str | None = None):
        if not 1 <= node_id <= 127:
            raise ValueError(f"node_id={node_id} is outside 1..127")
        self.twin = twin
        self.settings = settings
        self.node_id = node_id
        #: 0x1018 sub-index → value served in place of the EDS default (``identity``: vendor,
        #: product, revision, serial, as ``[simulation.drive_identity]`` states them)
        subs = {"vendor": 1, "product": 2, "revision": 3, "serial": 4}
        self.identity_values = {4: serial_number} | {subs[k]: int(v)
                                                     for k, v in (identity or {}).items()}
        self.serial_number = self.identity_values[4]
        #: 0x100A as read (None: the EDS default); the simulated bench names its plant here
        self.software_version = software_version
        self._eds_path = eds_path
        self._kt = torque_constant_nm_per_a or TABLE_I.torque_constant_nm_per_a
        profile = load_profile(profile, eds_path)
        self._knobs = {(obj.index, obj.subindex): obj for obj in profile.knobs.values()}
        command = profile.current_command
        self._current_command = command
        self._command_at = None if command is None else (command.index, command.subindex)
        restore = profile.restore
        self._restore_at = None if restore is None else (restore.index, restore.subindex)
        self._restore_value = None if restore is None else restore.value
        self._lock = threading.RLock()
        self._state = sm.SWITCH_ON_DISABLED
        self._controlword = 0
        self._error_code = 0
        self._error_register = 0
        self._heartbeat_stopped = False
        self._status_cache: tuple[float, dict] | None = None
        self._master_lost = False            # heartbeat error active (cleared when it resumes)
        self._twin_loss_pending = False      # master-loss action not yet applied to the twin
        self._twin_loss_disables = False     # ... and it includes twin.disable()
        self._twin_loss_lock = threading.Lock()
        self.heartbeat_consumer: HeartbeatConsumer | None = None
        self.network: canopen.Network | None = None
        self.node: DriveLocalNode | None = None
        self.pdo: PdoEngine | None = None

    # -- lifecycle --------------------------------------------------------------------------
    def start(self) -> "SimulatedDrive":
        od = load_dictionary(self._eds_path, self.node_id)
        self._supported_modes = od[0x6502].default
        self.network = canopen.Network(open_bus(self.settings))
        self.network.NOTIFIER_CYCLE = NOTIFIER_CYCLE_S  # bounds close() time
        self.network.connect()
        self.node = DriveLocalNode(self.node_id, od, validate_and_apply=self._validate_and_apply,
                                   after_store=self._after_store, on_nmt_reset=self._on_nmt_reset,
                                   on_nmt_state=self._on_nmt_state)
        self.node.emcy = SwitchableEmcyProducer(self.node.stored_value(COB_ID_EMCY_INDEX))
        self.node.add_read_callback(self._read_live)
        self.network.add_node(self.node)
        self.pdo = PdoEngine(self.node, self.network,
                             is_operational=lambda: self.node.nmt.state == "OPERATIONAL")
        self.pdo.reload()
        self.pdo.start()
        self.heartbeat_consumer = HeartbeatConsumer(self.network, on_timeout=self._on_master_lost,
                                                    on_resumed=self._on_master_back)
        self.heartbeat_consumer.start()
        with self.twin.lock:
            self.twin.disable()
        self.node.nmt.send_command(0x81)  # INITIALISING: boot-up message
        self.node.nmt.send_command(0x80)  # PRE-OPERATIONAL, heartbeat starts from 0x1017
        return self

    def stop(self) -> None:
        if self.network is None:
            return
        try:
            if self.heartbeat_consumer is not None:
                self.heartbeat_consumer.stop()
            self.twin.disable()
        finally:
            self.pdo.stop()
            self.node.nmt.stop_heartbeat()
            self.network.disconnect()
            self.network = None

    def __enter__(self) -> "SimulatedDrive":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()

    # -- test hooks -------------------------------------------------------------------------
    @property
    def state(self) -> str:
        with self._lock:
            return self._state

    def raise_fault(self, code: int = 0x2310, text: str = "overcurrent") -> None:
        """Enter FAULT (gates off) and send an EMCY with ``code`` and up to 5 bytes of ``text``."""
        with self._lock:
            self._error_code = code
            self._error_register = _error_register_for(code)
            self._set_state(sm.FAULT)
        self.node.emcy.send(code, self._error_register, text.encode("ascii", "replace")[:5])
        self.pdo.notify_change()

    def stop_heartbeat(self) -> None:
        """Go silent on the heartbeat (the node otherwise keeps working) — for loss tests."""
        with self._lock:
            self._heartbeat_stopped = True
            self.node.nmt.stop_heartbeat()

    def resume_heartbeat(self) -> None:
        """Start producing the heartbeat again at the period in 0x1017."""
        with self._lock:
            self._heartbeat_stopped = False
            period_ms = self.node.stored_value(0x1017)
            if period_ms:
                self.node.nmt.start_heartbeat(period_ms)

    # -- state machine ----------------------------------------------------------------------
    def _set_state(self, new_state: str, *, tell_twin: bool = True) -> None:
        """Change the CiA 402 state; ``tell_twin=False`` leaves the twin to the master-loss worker."""
        old_state, self._state = self._state, new_state
        if new_state == old_state:
            return
        logger.info("simulated drive %d: %s -> %s", self.node_id, old_state, new_state)
        if tell_twin and new_state == sm.OPERATION_ENABLED:
            self.twin.enable()
        elif tell_twin and _gates_go_off(old_state, new_state):
            self.twin.disable()
        if old_state == sm.FAULT and new_state != sm.FAULT:
            self._error_code = 0
            self._error_register = 0
            self.node.emcy.reset()

    def _on_controlword(self, controlword: int) -> None:
        with self._lock:
            new_state = sm.device_transition(self._state, controlword, self._controlword)
            self._controlword = controlword
            self._set_state(new_state)

    def _on_nmt_state(self, nmt_state: str) -> None:
        if nmt_state in ("STOPPED", "PRE-OPERATIONAL"):
            with self._lock:
                if self._state in (sm.OPERATION_ENABLED, sm.QUICK_STOP_ACTIVE, sm.SWITCHED_ON,
                                   sm.READY_TO_SWITCH_ON):
                    self._set_state(sm.SWITCH_ON_DISABLED)  # lost the master: gates off
        self.pdo.notify_change()

    def _on_nmt_reset(self, command: int) -> None:
        with self._lock:
            if self._state != sm.FAULT:
                self._set_state(sm.SWITCH_ON_DISABLED)
            self.twin.disable()
            if command == 0x81:  # reset node: application parameters too
                self.node.data_store.clear()
                self.twin.restore_defaults()
            else:                # reset communication: 0x1000..0x1FFF
                for index in [i for i in self.node.data_store if 0x1000 <= i <= 0x1FFF]:
                    del self.node.data_store[index]
            self._heartbeat_stopped = False
        self.pdo.reload()
        self.node.emcy.set_entry(self.node.stored_value(COB_ID_EMCY_INDEX))
        self.pdo.set_sync_cob_id(self.node.stored_value(COB_ID_SYNC_INDEX))
        self._configure_heartbeat_consumer()

    # -- object writes ----------------------------------------------------------------------
    def _validate_and_apply(self, index: int, subindex: int, od, data: bytes) -> None:
        self._apply_master_loss_to_twin()  # a write after a master loss comes after its action
        value = od.decode_raw(data)
        if index == 0x6040:
            self._on_controlword(value)
        elif index == 0x6060:
            supported = value in sm.MODE_CODES.values() and \
                self._supported_modes & sm.supported_mode_bit(value)
            if not supported:
                raise SdoAbortedError(ABORT_VALUE_RANGE)
        elif (index, subindex) in self._knobs:
            knob = self._knobs[index, subindex]
            try:
                self.twin.set_injection(**{knob.knob: knob.to_si(value)})
            except ValueError as exc:
                logger.info("simulated drive: %s rejected: %s", knob.knob, exc)
                raise SdoAbortedError(ABORT_VALUE_RANGE) from None
        elif (index, subindex) == self._restore_at:
            if value != self._restore_value:
                raise SdoAbortedError(ABORT_CANNOT_STORE)
            self.twin.restore_defaults()
        elif (index, subindex) == self._command_at:
            self._apply_twin_attribute("current_command_a", self._current_command.to_si(value))
        elif index == 0x6071:
            torque_nm = value / 1000.0 * self._rated_torque_nm()
            self._apply_twin_attribute("current_command_a", torque_nm / self._kt)
        elif index == 0x60FF:
            self._apply_twin_attribute("speed_rpm", float(value))
        elif 0x1600 <= index <= 0x17FF or 0x1A00 <= index <= 0x1BFF:
            if subindex and not validate_mapping_entry(self.node, value):
                raise SdoAbortedError(0x06040041)  # object cannot be mapped to the PDO
        elif index == CONSUMER_HEARTBEAT_INDEX:
            check_consumer_write(self.node, subindex, value)

    def _apply_twin_attribute(self, name: str, value: float) -> None:
        try:
            with self.twin.lock:
                setattr(self.twin, name, value)
        except ValueError as exc:
            logger.info("simulated drive: %s=%r rejected: %s", name, value, exc)
            raise SdoAbortedError(ABORT_VALUE_RANGE) from None

    def _after_store(self, index: int, subindex: int, od, data: bytes) -> None:
        if is_pdo_config_index(index):
            self.pdo.reload()
        elif index == CONSUMER_HEARTBEAT_INDEX:
            self._configure_heartbeat_consumer()
        elif index == COB_ID_EMCY_INDEX:
            self.node.emcy.set_entry(od.decode_raw(data))
        elif index == COB_ID_SYNC_INDEX:
            self.pdo.set_sync_cob_id(od.decode_raw(data))
        elif index == 0x1017:
            heartbeat_ms = od.decode_raw(data)
            with self._lock:
                if self._heartbeat_stopped or heartbeat_ms == 0:
                    self.node.nmt.stop_heartbeat()
                else:
                    self.node.nmt.start_heartbeat(heartbeat_ms)
        self.pdo.notify_change()

    # -- object reads -----------------------------------------------------------------------
    def _status(self) -> dict:
        """The twin's latest scalars, cached for 1 ms. While another thread holds the twin
        (a long ``advance`` for a capture) the last known values are used, so TPDOs keep flowing."""
        now = time.monotonic()
        cached = self._status_cache
        if cached is not None and now - cached[0] <= _STATUS_CACHE_S:
            return cached[1]
        if not self.twin.lock.acquire(blocking=cached is None):
            return cached[1]
        try:
            cached = (now, self.twin.status())
        finally:
            self.twin.lock.release()
        self._status_cache = cached
        return cached[1]

    def _per_mille_of_rated(self, torque_nm: float) -> int:
        return max(-32768, min(32767, round(torque_nm / self._rated_torque_nm() * 1000.0)))

    def _rated_torque_nm(self) -> float:
        """Motor rated torque 0x6076 as stored now (mN*m on the bus; LowLimit 1)."""
        return self.node.stored_value(0x6076) / 1000.0

    def _read_live(self, index: int, subindex: int, od):
        if index == 0x6041:
            with self._lock:
                return sm.statusword_for(self._state)
        if index == 0x6061:
            return self.node.stored_value(0x6060)
        if index == 0x6064:
            counts = int(self._status()["position_counts"]) & 0xFFFFFFFF  # INTEGER32 wraps
            return counts - (1 << 32) if counts & 0x80000000 else counts
        if index == 0x606C:
            return round(self._status()["speed_rpm"])
        if index == 0x6077:
            return self._per_mille_of_rated(self._status()["torque_em_nm"])
        if (index, subindex) in self._knobs:
            knob = self._knobs[index, subindex]
            if self._twin_loss_pending:  # reset by the master-loss action; the twin is busy
                return knob.default_count
            return knob.to_count(getattr(self.twin.injection, knob.knob))
        if (index, subindex) == self._restore_at:
            return 1  # CiA 301 convention: "restores on command"
        if index == 0x100A and self.software_version:
            return self.software_version
        if (index, subindex) == self._command_at:
            return self._current_command.to_count(self.twin.current_command_a)
        if index == 0x6071:
            return self._per_mille_of_rated(self.twin.current_command_a * self._kt)
        if index == 0x60FF:
            return round(self.twin.speed_rpm)
        if index == 0x603F:
            return self._error_code
        if index == 0x1001:
            return self._error_register
        if index == 0x1018 and subindex in self.identity_values:
            return self.identity_values[subindex]
        return None

    # -- master-loss detection (heartbeat consumer 0x1016, abort connection option 0x6007) ---
    def _configure_heartbeat_consumer(self) -> None:
        self.heartbeat_consumer.configure(consumer_entries(self.node))

    @property
    def master_lost(self) -> bool:
        """True from a heartbeat-consumer timeout until that producer's heartbeat comes back."""
        with self._lock:
            return self._master_lost

    def _state_after_master_loss(self, option: int) -> str:
        """The CiA 402 state the abort connection option code 0x6007 leads to."""
        if option == ABORT_OPTION_FAULT:
            return sm.FAULT
        if option == ABORT_OPTION_DISABLE_VOLTAGE:
            return sm.device_transition(self._state, sm.CW_DISABLE_VOLTAGE, self._controlword)
        if option == ABORT_OPTION_QUICK_STOP:
            return sm.device_transition(self._state, sm.CW_QUICK_STOP, self._controlword)
        return self._state

    def _on_master_lost(self, producer_id: int) -> None:
        """Heartbeat-consumer timeout: EMCY 0x8130, the 0x6007 action, injections to defaults.

        The statusword changes here at once; the twin takes the action in a worker thread when
        its lock is free (a real drive's gates go off at once).
        """
        option = self.node.stored_value(ABORT_CONNECTION_OPTION_INDEX)
        register = _error_register_for(EMCY_HEARTBEAT_ERROR)
        with self._lock:
            self._master_lost = True
            self._error_code = EMCY_HEARTBEAT_ERROR
            self._error_register = register
        logger.warning("simulated drive %d: master (node %d) lost; abort connection option %d",
                       self.node_id, producer_id, option)
        self.node.emcy.send(EMCY_HEARTBEAT_ERROR, register, bytes([producer_id]))
        with self._lock:
            new_state = self._state_after_master_loss(option)
            self._twin_loss_disables = new_state != sm.OPERATION_ENABLED or (
                self._twin_loss_pending and self._twin_loss_disables)
            self._twin_loss_pending = True
            self._set_state(new_state, tell_twin=False)
        self.pdo.notify_change()
        threading.Thread(target=self._apply_master_loss_to_twin, name="sim-drive-master-loss",
                         daemon=True).start()

    def _apply_master_loss_to_twin(self) -> None:
        """Give the twin a pending master-loss action (waits for the twin's lock).

        Takes only the twin's lock, never the node's, so statusword reads and the state machine
        keep working while a capture holds the twin.
        """
        if not self._twin_loss_pending:
            return
        with self._twin_loss_lock:
            if not self._twin_loss_pending:
                return
            if self._twin_loss_disables:
                # before the lock: a plant computing a stretch under it abandons the stretch
                # (hil.plants.motulator_plant) instead of finishing it with the gates on
                self.twin.disable()
            with self.twin.lock:
                if self._twin_loss_disables:
                    self.twin.disable()
                self.twin.restore_defaults()
                self._twin_loss_pending = False
        logger.info("simulated drive %d: master-loss action applied to the twin", self.node_id)

    def _on_master_back(self, producer_id: int) -> None:
        """The lost producer's heartbeat is back: EMCY 0x0000 unless the drive is in FAULT."""
        with self._lock:
            self._master_lost = False
            if self._state in (sm.FAULT, sm.FAULT_REACTION_ACTIVE):
                return   # cleared by the master's fault reset
            self._error_code = 0
            self._error_register = 0
        self.node.emcy.reset()
