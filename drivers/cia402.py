"""Master-side driver of the CiA 402 PMSM drive over CANopen (``canopen`` + ``python-can``).

Everything about the drive's dictionary comes from its EDS (default: the shipped one,
``ripple_hil_drivers.canopen_eds``); which object carries each injection knob and the current
command, and how they scale and restore, from its drive profile (``ripple_hil_drivers.drive_profile``;
default: the shipped drive's).
The driver does its own CiA 402 state handling on a ``canopen.RemoteNode`` instead of using
``canopen.BaseNode402``, whose 2.4.x version asserts the NMT state with a substring test in
``setup_pdos()``, swallows errors in the ``op_mode`` setter and has a ``reset_from_fault()`` that
never produces the rising edge of the fault-reset bit. Here every step has a timeout and raises a
typed error (``ripple_hil_drivers.errors``) naming the instrument and what it was doing. A lost bus (the CAN
interface, or the TCP link of a remote bus, gone: a send fails or the receive thread sees an error)
makes every later failure ``TransportLost`` with the operating system's reason, raised from the
original error, not a timeout.

Cyclic objects (configured by ``connect``, asynchronous with an event timer):
RPDO1 = controlword 0x6040; TPDO1 = statusword 0x6041 + mode display 0x6061;
TPDO2 = torque actual 0x6077 + velocity actual 0x606C; TPDO3 = position actual 0x6064.
Commands: current command through the profile's object (shipped: 0x2100 ``current_command_a [mA]``)
or, when the profile names none, target torque 0x6071 in per mille of the rated current 0x6075
(= of the rated torque 0x6076); target torque 0x6071 in per mille of 0x6076; target velocity
0x60FF in rpm.

Master-loss detection (CiA 301 / CiA 402): ``connect`` starts this master's own heartbeat
(COB-ID 0x700 + ``master_node_id``, state byte 0x05, period ``heartbeat_timeout_s / 4``) and
makes the drive consume it (0x1016:01 = ``master_node_id << 16`` | ``heartbeat_timeout_s`` in ms,
verified by read-back). If this process dies, the drive performs its abort connection option
0x6007 (default: disable voltage) and restores its injections to defaults. A clean ``close()``
first writes 0x1016:01 = 0, so the drive stays as the bench left it, then stops the heartbeat.
"""

from __future__ import annotations

import logging
import math
import threading
import time

import can
import canopen
from canopen.sdo.base import SdoVariable
from canopen.sdo.exceptions import SdoAbortedError, SdoCommunicationError

from ripple_hil_drivers import canopen_402 as sm
from ripple_hil_drivers.canopen_eds import ScaledObject, load_dictionary
from ripple_hil_drivers.canopen_transport import NOTIFIER_CYCLE_S, BusLossWatch, CanBusSettings, open_bus
from ripple_hil_drivers.drive_profile import DriveProfile, load_profile, plan_knobs
from ripple_hil_drivers.errors import (DeviceFault, HeartbeatLost, InjectionRangeError, InstrumentError,
                            InstrumentTimeout, ProtocolError, TransportLost, transport_reason)
from hil.errors import InputError

logger = logging.getLogger(__name__)

#: Errors that a lost bus explains: raised as TransportLost once the bus is known to be lost.
LOSS_SYMPTOMS = (InstrumentError, InstrumentTimeout, HeartbeatLost)
CIA402_PROFILE = 402
VALUE_RANGE_ABORTS = (0x06090030, 0x06090031, 0x06090032)
NMT_OPERATIONAL = 5
CONSUMER_HEARTBEAT_INDEX = 0x1016
HEARTBEAT_COB_BASE = 0x700
DEFAULT_MASTER_NODE_ID = 0x7F
#: 0x1018 sub-indices read when the EDS lists them: (sub, identity key, what).
IDENTITY_SUBS = ((1, "vendor", "vendor-ID"), (2, "product", "product code"),
                 (3, "revision", "revision number"), (4, "serial", "serial number"))
#: Optional CiA 301 text objects read when the EDS lists them.
OPTIONAL_TEXT_OBJECTS = ((0x1008, "device_name"), (0x100A, "firmware"))

_NEXT_COMMAND_TOWARDS_ENABLED = {
    sm.SWITCH_ON_DISABLED: sm.CW_SHUTDOWN,
    sm.READY_TO_SWITCH_ON: sm.CW_SWITCH_ON,
    sm.SWITCHED_ON: sm.CW_ENABLE_OPERATION,
    sm.QUICK_STOP_ACTIVE: sm.CW_DISABLE_VOLTAGE,
    sm.NOT_READY: sm.CW_DISABLE_VOLTAGE,
}


class Cia402Drive:
    """A CiA 402 drive on a CAN bus: state machine, modes, commands, fault injection, health."""

    def __init__(self, settings: CanBusSettings, node_id: int = 5, eds_path=None, *,
                 sdo_timeout_s: float = 0.5, heartbeat_timeout_s: float = 0.5,
                 instrument_name: str = "drive", tpdo_event_timer_ms: int = 10,
                 master_node_id: int = DEFAULT_MASTER_NODE_ID,
                 profile: DriveProfile | str | None = None) -> None:
        if not 1 <= int(node_id) <= 127:
            raise InputError(f"drive.node_id={node_id!r} is outside 1..127")
        if not 1 <= int(master_node_id) <= 127 or int(master_node_id) == int(node_id):
            raise InputError(f"drive master_node_id={master_node_id!r} is outside 1..127 or equals "
                             f"the drive's node_id {node_id!r}")
        if not 0.01 <= sdo_timeout_s <= 10:
            raise InputError(f"drive sdo_timeout_s={sdo_timeout_s!r} is outside 0.01..10 s")
        if not 0.02 <= heartbeat_timeout_s <= 60:
            raise InputError(f"drive heartbeat_timeout_s={heartbeat_timeout_s!r} is outside "
                             f"0.02..60 s")
        if not 1 <= tpdo_event_timer_ms <= 1000:
            raise InputError(f"drive tpdo_event_timer_ms={tpdo_event_timer_ms!r} is outside 1..1000")
        self.settings = settings
        self.node_id = int(node_id)
        self.eds_path = eds_path
        self.sdo_timeout_s = sdo_timeout_s
        self.heartbeat_timeout_s = heartbeat_timeout_s
        self.instrument_name = instrument_name
        self.tpdo_event_timer_ms = tpdo_event_timer_ms
        self.master_node_id = int(master_node_id)
        self._master_heartbeat = None      # canopen PeriodicMessageTask of this master's heartbeat
        self._drive_consumes_heartbeat = False
        self.profile = profile if isinstance(profile, DriveProfile) else load_profile(profile, eds_path)
        self._knobs = self.profile.knobs
        self._current_command = self.profile.current_command
        self._lock = threading.RLock()
        self._tpdo_update = threading.Condition()
        self._heartbeat_update = threading.Condition()
        self._tpdo_values: dict[int, int] = {}
        self._tpdo_time: dict[int, float] = {}
        self._last_heartbeat: float | None = None
        self._heartbeat_state: int | None = None
        self._connected_at: float | None = None
        self._producer_period_s = self.producer_heartbeat_ms / 1000.0
        self._emcy: canopen.emcy.EmcyError | None = None
        self._identity: dict | None = None
        #: Called with the identity read at connect, before anything is written to the drive
        #: (heartbeat, PDOs, NMT): raising refuses the drive (``hil.dut``: the unit's serial).
        self.identity_check = None
        self._rated_torque_cache_nm: float | None = None
        self.network: canopen.Network | None = None
        self.node: canopen.RemoteNode | None = None
        self._loss_watch: BusLossWatch | None = None

    # -- errors -----------------------------------------------------------------------------
    def _error(self, cls, action: str, detail: str) -> InstrumentError:
        """A ``cls`` error, or ``TransportLost`` (caused by the loss) if the bus is lost and a
        lost bus explains a ``cls`` failure (a timeout, a silent heartbeat, a bus error)."""
        lost = self.bus_lost()
        if lost is not None and cls in LOSS_SYMPTOMS:
            error = TransportLost(self.instrument_name, action, transport_reason(lost),
                                  what="CAN bus lost")
            error.__cause__ = lost
            return error
        return cls(self.instrument_name, action, detail)

    def bus_lost(self) -> BaseException | None:
        """The error that broke the CAN bus (a failed send, or the receive thread's error), or
        None while it works."""
        watch, network = self._loss_watch, self.network
        if watch is None or network is None:
            return None
        return watch.lost(network.bus)

    @staticmethod
    def _raise(error: InstrumentError, original: BaseException):
        """Raise ``error`` from the bus loss it stands for, else from ``original``."""
        raise error from (error.__cause__ or original)

    def _sdo(self, action: str, func):
        """Run one bus transaction (SDO, NMT, PDO configuration); typed errors."""
        try:
            return func()
        except SdoAbortedError as exc:
            if exc.code in VALUE_RANGE_ABORTS:
                raise self._error(InjectionRangeError, action, f"drive refused the value: {exc}") from exc
            raise self._error(ProtocolError, action, f"SDO abort: {exc}") from exc
        except SdoCommunicationError as exc:
            if "No SDO response" in str(exc):
                self._raise(self._error(InstrumentTimeout, action,
                                        f"no SDO answer within {self.sdo_timeout_s} s"), exc)
            self._raise(self._error(ProtocolError, action, f"SDO error: {exc}"), exc)
        except (can.CanError, OSError) as exc:
            self._raise(self._bus_error(action, exc), exc)

    def _bus_error(self, action: str, exc: BaseException) -> InstrumentError:
        """A failed send: TransportLost if the bus is known lost or the OS said why, else a plain
        InstrumentError (a bus error that does not mean the bus is gone)."""
        if self.bus_lost() is None and any(isinstance(e, OSError) for e in
                                           (exc, exc.__cause__, exc.__context__)):
            error = TransportLost(self.instrument_name, action, transport_reason(exc),
                                  what="CAN bus lost")
            error.__cause__ = exc
            return error
        return self._error(InstrumentError, action, f"CAN bus error: {exc}")

    def _require_node(self, action: str) -> canopen.RemoteNode:
        if self.node is None:
            raise self._error(InstrumentError, action, "not connected (call connect())")
        return self.node

    def sdo_read(self, index: int, subindex: int = 0, *, action: str | None = None):
        """Upload one object by SDO; typed errors on abort or timeout."""
        action = action or f"SDO read 0x{index:04X}:{subindex:02X}"
        variable = self._sdo_variable(index, subindex, action)
        with self._lock:
            return self._sdo(action, lambda: variable.raw)

    def sdo_write(self, index: int, subindex: int, value, *, action: str | None = None) -> None:
        """Download one object by SDO; typed errors on abort or timeout."""
        action = action or f"SDO write 0x{index:04X}:{subindex:02X}={value!r}"
        variable = self._sdo_variable(index, subindex, action)

        def write():
            variable.raw = value
        with self._lock:
            self._sdo(action, write)
            if index == 0x6076:
                self._rated_torque_cache_nm = None   # motor rated torque (rw) changed

    def _sdo_variable(self, index: int, subindex: int, action: str):
        node = self._require_node(action)
        try:
            entry = node.sdo[index]
            return entry if isinstance(entry, SdoVariable) else entry[subindex]
        except KeyError:
            raise InputError(f"object 0x{index:04X}:{subindex:02X} is not in the drive's EDS") from None

    def _write_verified(self, index: int, value: int, action: str, subindex: int = 0) -> None:
        self.sdo_write(index, subindex, value, action=action)
        read_back = self.sdo_read(index, subindex, action=f"{action}: read back")
        if read_back != value:
            raise self._error(ProtocolError, action, f"read back {read_back!r}, wrote {value!r}")

    # -- connection -------------------------------------------------------------------------
    def connect(self) -> "Cia402Drive":
        """Open the bus, check the device is a CiA 402 drive, configure PDOs and heartbeat, start."""
        action = f"connect to node {self.node_id} on {self.settings.interface}:{self.settings.channel}"
        try:
            bus = open_bus(self.settings)
        except (can.CanError, OSError) as exc:
            if isinstance(exc, OSError) or isinstance(exc.__cause__ or exc.__context__, OSError):
                raise TransportLost(self.instrument_name, action, transport_reason(exc),
                                    what="cannot open CAN bus") from exc
            raise self._error(InstrumentError, action, f"cannot open CAN bus: {exc}") from exc
        except (ValueError, ImportError) as exc:
            raise self._error(InstrumentError, action, f"cannot open CAN bus: {exc}") from exc
        self.network = canopen.Network(bus)
        self.network.NOTIFIER_CYCLE = NOTIFIER_CYCLE_S  # bounds close() time
        self.network.connect()
        self._loss_watch = BusLossWatch()
        self.network.notifier.add_listener(self._loss_watch)
        node = canopen.RemoteNode(self.node_id, load_dictionary(self.eds_path, self.node_id))
        node.sdo.RESPONSE_TIMEOUT = self.sdo_timeout_s
        node.sdo.MAX_RETRIES = 1  # canopen counts attempts: 1 = no retry; 0 would retry forever
        self.network.add_node(node)
        node.nmt.add_heartbeat_callback(self._on_heartbeat)
        node.emcy.add_callback(self._on_emcy)
        self.node = node
        self._connected_at = time.monotonic()
        try:
            device_type = self.sdo_read(0x1000, action=f"{action}: read device type 0x1000")
            if device_type & 0xFFFF != CIA402_PROFILE:
                raise self._error(ProtocolError, action,
                                  f"device type 0x{device_type:08X} is not a CiA 402 device")
            self._identity = self._read_identity()
            if self.identity_check is not None:
                self.identity_check(dict(self._identity))
            self._sdo(f"{action}: NMT pre-operational",   # PDO configuration allowed
                      lambda: node.nmt.send_command(0x80))
            self._write_verified(0x1017, self.producer_heartbeat_ms, f"{action}: set producer heartbeat time")
            self._start_master_heartbeat(action)
            self._configure_pdos(action)
            with self._heartbeat_update:
                self._heartbeat_state = None  # wait for a heartbeat sent after the command
            self._sdo(f"{action}: NMT operational", lambda: node.nmt.send_command(0x01))
            self._wait_heartbeat_state(NMT_OPERATIONAL, time.monotonic() + 3 * self.heartbeat_timeout_s,
                                       f"{action}: heartbeat showing OPERATIONAL")
            self._wait_tpdo(0x6041, time.monotonic() + max(1.0, 10 * self.tpdo_event_timer_ms / 1000),
                            f"{action}: first statusword TPDO")
        except BaseException:
            self.close()
            raise
        return self

    @property
    def producer_heartbeat_ms(self) -> int:
        """The drive's heartbeat period written to 0x1017: a quarter of the consumer time."""
        return max(1, int(self.heartbeat_timeout_s * 1000 / 4))

    @property
    def consumer_heartbeat_entry(self) -> int:
        """The 0x1016:01 value written to the drive: master node id << 16 | timeout in ms."""
        return self.master_node_id << 16 | round(self.heartbeat_timeout_s * 1000)

    def _start_master_heartbeat(self, action: str) -> None:
        """Make the drive consume this master's heartbeat (0x1016:01, verified), then produce it.

        The drive monitors from the first heartbeat it receives (CiA 301); the periodic task
        sends its first frame at once, so monitoring starts before ``connect`` returns.
        """
        self._drive_consumes_heartbeat = True   # from here on close() clears 0x1016:01
        self._write_verified(CONSUMER_HEARTBEAT_INDEX, self.consumer_heartbeat_entry,
                             f"{action}: set the drive's consumer heartbeat 0x1016:01", subindex=1)
        try:
            self._master_heartbeat = self.network.send_periodic(
                HEARTBEAT_COB_BASE + self.master_node_id, bytes([NMT_OPERATIONAL]),
                self.heartbeat_timeout_s / 4)
        except (can.CanError, OSError) as exc:
            self._raise(self._bus_error(f"{action}: start the master heartbeat", exc), exc)

    def _stop_master_heartbeat(self) -> None:
        """Clean-close path: stop the drive consuming our heartbeat, then stop producing it.

        If the drive cannot be told (bus or drive gone), the heartbeat stops anyway and the
        drive takes its master-loss action (0x6007) — the safe outcome.
        """
        if self._drive_consumes_heartbeat:
            self._drive_consumes_heartbeat = False
            try:
                self.sdo_write(CONSUMER_HEARTBEAT_INDEX, 1, 0,
                               action="close: stop the drive's consumer heartbeat 0x1016:01")
            except (InstrumentError, RuntimeError) as exc:  # RuntimeError: bus already closed
                logger.warning("%s; the drive will take its master-loss action", exc)
        task, self._master_heartbeat = self._master_heartbeat, None
        if task is not None:
            try:
                task.stop()
            except Exception:  # noqa: BLE001 - a broken bus has stopped it already
                logger.debug("drive: stopping the master heartbeat failed", exc_info=True)

    def _configure_pdos(self, action: str) -> None:
        node = self.node
        layout = {
            ("rpdo", 1): [0x6040],
            ("tpdo", 1): [0x6041, 0x6061],
            ("tpdo", 2): [0x6077, 0x606C],
            ("tpdo", 3): [0x6064],
        }
        for kind, base in (("rpdo", 0x200), ("tpdo", 0x180)):
            maps = getattr(node, kind)
            for number in range(1, 5):
                pdo_map = maps[number]
                pdo_map.clear()
                for index in layout.get((kind, number), []):
                    pdo_map.add_variable(index)
                pdo_map.cob_id = base + 0x100 * (number - 1) + self.node_id
                pdo_map.enabled = (kind, number) in layout
                pdo_map.trans_type = 255
                if kind == "tpdo":
                    pdo_map.event_timer = self.tpdo_event_timer_ms
                self._sdo(f"{action}: configure {kind.upper()}{number}", pdo_map.save)
                if kind == "tpdo" and pdo_map.enabled:
                    pdo_map.add_callback(self._on_tpdo)
        self._controlword_pdo = node.rpdo[1]

    def close(self) -> None:
        """Leave the drive as it is (the safety guard disables it first) and release the bus.

        The drive stops consuming this master's heartbeat before the heartbeat stops, so a
        clean close does not trip the drive's master-loss action.
        """
        if self.network is not None:
            self._stop_master_heartbeat()
        network, self.network, self.node = self.network, None, None
        self._rated_torque_cache_nm = None
        if network is not None:
            if self._loss_watch is not None and self._loss_watch.error is not None:
                network.notifier.exception = None   # kept and raised already (TransportLost)
            try:
                network.disconnect()
            except Exception:  # already broken bus: nothing more to release
                logger.debug("drive: network disconnect failed", exc_info=True)

    def __enter__(self) -> "Cia402Drive":
        return self.connect()

    def __exit__(self, *exc) -> None:
        self.close()

    def _read_identity(self) -> dict:
        """CiA 301 identity: 0x1018 (mandatory; sub 1 vendor-ID mandatory, subs 2..4 optional)
        and the optional 0x1008 device name / 0x100A software version, each read only when the
        EDS lists it (a device need not have them)."""
        od = self._require_node("read identity").object_dictionary
        if 0x1018 not in od or 1 not in od[0x1018]:
            raise self._error(ProtocolError, "read identity",
                              "the EDS lacks the mandatory identity object 0x1018:01")
        identity = {}
        for sub, key, what in IDENTITY_SUBS:
            if sub in od[0x1018]:
                identity[key] = self.sdo_read(0x1018, sub,
                                              action=f"read identity {what} 0x1018:{sub:02X}")
        for index, key in OPTIONAL_TEXT_OBJECTS:
            if index in od:
                value = self.sdo_read(index, action=f"read identity 0x{index:04X}")
                identity[key] = value if isinstance(value, str) else \
                    bytes(value).decode("ascii", "replace")
        return identity

    def identity(self) -> dict:
        """Vendor-ID, product code, revision, serial number, device name, firmware version."""
        if self._identity is None:
            self._identity = self._read_identity()
        return dict(self._identity)

    # -- bus events -------------------------------------------------------------------------
    def _on_heartbeat(self, nmt_state: int) -> None:
        with self._heartbeat_update:
            self._last_heartbeat = time.monotonic()
            self._heartbeat_state = nmt_state
            self._heartbeat_update.notify_all()

    def _check_heartbeat(self, action: str) -> None:
        """HeartbeatLost once the drive has been silent for the consumer time (CiA 301).

        Tolerance: one producer period. A check made between the consumer time and one producer
        period after it waits until then for a heartbeat already on its way (this process's
        receive thread may lag on a loaded machine); a producer that is really silent is declared
        lost at most one producer period after the consumer time. The message states the silence
        measured when it is raised.
        """
        with self._heartbeat_update:
            last = self._last_heartbeat
            since = last if last is not None else self._connected_at
            if since is None or time.monotonic() - since <= self.heartbeat_timeout_s:
                return
            grace_end = since + self.heartbeat_timeout_s + self._producer_period_s
            while self._last_heartbeat == last and (remaining := grace_end - time.monotonic()) > 0:
                self._heartbeat_update.wait(remaining)
            if self._last_heartbeat != last:
                logger.warning("%s: heartbeat late (consumer time %s s)", self.instrument_name,
                               self.heartbeat_timeout_s)
                return
            silence_s = time.monotonic() - since
        what = "no heartbeat" if last is not None else "no heartbeat since connect"
        raise self._error(HeartbeatLost, action,
                          f"{what} from node {self.node_id} for {silence_s:.3f} s (consumer time "
                          f"{self.heartbeat_timeout_s:g} s, producer period "
                          f"{self._producer_period_s:g} s)")

    def _wait_heartbeat_state(self, nmt_state: int, deadline: float, action: str) -> None:
        with self._heartbeat_update:
            while self._heartbeat_state != nmt_state:
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    raise self._error(HeartbeatLost, action,
                                      f"heartbeat state {self._heartbeat_state}, expected {nmt_state}")
                self._heartbeat_update.wait(remaining)

    def _on_emcy(self, error) -> None:
        logger.warning("%s: EMCY %s", self.instrument_name, error)
        self._emcy = error if error.code != 0 else None

    @property
    def last_emcy(self):
        """The last EMCY with a non-zero code since connect or fault reset (``canopen.emcy.EmcyError``)."""
        return self._emcy

    def _on_tpdo(self, pdo_map) -> None:
        now = time.monotonic()
        with self._tpdo_update:
            for variable in pdo_map:
                self._tpdo_values[variable.index] = variable.raw
                self._tpdo_time[variable.index] = now
            self._tpdo_update.notify_all()

    def _wait_tpdo(self, index: int, deadline: float, action: str, *, newer_than: float = 0.0) -> int:
        with self._tpdo_update:
            while self._tpdo_time.get(index, -1.0) <= newer_than:
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    raise self._error(InstrumentTimeout, action,
                                      f"no TPDO with 0x{index:04X} before the timeout")
                self._tpdo_update.wait(remaining)
            return self._tpdo_values[index]

    def _fresh_tpdo(self, index: int):
        """The latest TPDO value of ``index`` if younger than three event periods, else None."""
        with self._tpdo_update:
            stamp = self._tpdo_time.get(index)
            if stamp is None or time.monotonic() - stamp > max(0.1, 3 * self.tpdo_event_timer_ms / 1000):
                return None
            return self._tpdo_values[index]

    # -- CiA 402 state machine --------------------------------------------------------------
    @property
    def statusword(self) -> int:
        value = self._fresh_tpdo(0x6041)
        if value is None:
            value = self.sdo_read(0x6041, action="read statusword 0x6041")
        return value

    @property
    def state(self) -> str:
        """CiA 402 state name decoded from the latest statusword (TPDO, or SDO if stale)."""
        return sm.state_from_statusword(self.statusword)

    def _send_controlword(self, controlword: int, action: str) -> float:
        """Send the controlword by RPDO1; returns the monotonic time just before sending."""
        self._require_node(action)
        sent_at = time.monotonic()
        with self._lock:
            self._controlword_pdo[0x6040].raw = controlword
            try:
                self._controlword_pdo.transmit()
            except (can.CanError, OSError) as exc:
                self._raise(self._bus_error(action, exc), exc)
        return sent_at

    def _await_state(self, wanted: tuple[str, ...], sent_at: float, deadline: float,
                     action: str) -> str:
        """Wait for a statusword TPDO received after ``sent_at`` showing one of ``wanted``."""
        newer_than = sent_at
        while True:
            try:
                statusword = self._wait_tpdo(0x6041, deadline, action, newer_than=newer_than)
                newer_than = self._tpdo_time[0x6041]
            except InstrumentTimeout:
                statusword = self.sdo_read(0x6041, action=f"{action}: read statusword")
                state = sm.state_from_statusword(statusword)
                if state in wanted:
                    return state
                raise self._error(InstrumentTimeout, action,
                                  f"drive stayed in {state}, expected {' or '.join(wanted)}") from None
            state = sm.state_from_statusword(statusword)
            if state in wanted:
                return state

    def _command(self, controlword: int, wanted: tuple[str, ...], deadline: float,
                 action: str) -> str:
        sent_at = self._send_controlword(controlword, action)
        return self._await_state(wanted, sent_at, deadline, action)

    def enable(self, timeout_s: float = 1.0) -> None:
        """Shutdown → switch on → enable operation, until OPERATION ENABLED (CiA 402 2, 3, 4)."""
        deadline = time.monotonic() + timeout_s
        action = "enable operation"
        self.check_health()
        state = self.state
        while state != sm.OPERATION_ENABLED:
            if state in (sm.FAULT, sm.FAULT_REACTION_ACTIVE):
                raise self._error(DeviceFault, action, f"drive is in {state}; call fault_reset()")
            command = _NEXT_COMMAND_TOWARDS_ENABLED.get(state)
            if command is None:
                raise self._error(ProtocolError, action, f"unexpected drive state {state}")
            if time.monotonic() >= deadline:
                raise self._error(InstrumentTimeout, action, f"drive still in {state} after {timeout_s} s")
            target = sm.device_transition(state, command, 0)
            state = self._command(command, (target, sm.FAULT), deadline, f"{action}: {state} → {target}")

    def quick_stop(self, timeout_s: float = 1.0) -> str:
        """Quick stop: OPERATION ENABLED → QUICK STOP ACTIVE (others → SWITCH ON DISABLED)."""
        deadline = time.monotonic() + timeout_s
        state = self.state
        if state in (sm.SWITCH_ON_DISABLED, sm.FAULT, sm.QUICK_STOP_ACTIVE, sm.NOT_READY):
            return state
        wanted = (sm.QUICK_STOP_ACTIVE,) if state == sm.OPERATION_ENABLED else (sm.SWITCH_ON_DISABLED,)
        return self._command(sm.CW_QUICK_STOP, wanted + (sm.FAULT,), deadline, "quick stop")

    def disable(self, timeout_s: float = 1.0) -> str:
        """Disable voltage → SWITCH ON DISABLED (gates off). A drive in FAULT is left there."""
        deadline = time.monotonic() + timeout_s
        state = self.state
        if state in (sm.SWITCH_ON_DISABLED, sm.FAULT, sm.FAULT_REACTION_ACTIVE):
            return state
        return self._command(sm.CW_DISABLE_VOLTAGE, (sm.SWITCH_ON_DISABLED, sm.FAULT), deadline,
                             "disable voltage")

    def fault_reset(self, timeout_s: float = 1.0) -> str:
        """Rising edge of controlword bit 7 in FAULT → SWITCH ON DISABLED (transition 15).

        Whether the drive is in FAULT is read over SDO, not from the latest TPDO: right after an
        EMCY the last statusword TPDO can still be the one sent before the fault (its FAULT
        statusword not dispatched yet), and the reset would be skipped."""
        deadline = time.monotonic() + timeout_s
        state = sm.state_from_statusword(
            self.sdo_read(0x6041, action="fault reset: read statusword 0x6041"))
        if state not in (sm.FAULT, sm.FAULT_REACTION_ACTIVE):
            self._emcy = None       # an EMCY without a fault (a warning): acknowledged
            return state
        self._send_controlword(sm.CW_DISABLE_VOLTAGE, "fault reset: clear bit 7")
        state = self._command(sm.CW_FAULT_RESET, (sm.SWITCH_ON_DISABLED,), deadline, "fault reset")
        self._send_controlword(sm.CW_DISABLE_VOLTAGE, "fault reset: release bit 7")
        self._emcy = None
        return state

    # -- modes and commands -----------------------------------------------------------------
    def set_mode(self, mode: str, timeout_s: float | None = None) -> None:
        """Write modes of operation 0x6060 and wait for 0x6061 to confirm it."""
        action = f"set mode of operation {mode!r}"
        if mode not in sm.MODE_CODES:
            raise InputError(f"drive mode {mode!r} is not one of {sorted(sm.MODE_CODES)}")
        code = sm.MODE_CODES[mode]
        supported = self.sdo_read(0x6502, action=f"{action}: read supported drive modes 0x6502")
        if not supported & sm.supported_mode_bit(code):
            names = [name for name, c in sm.MODE_CODES.items() if supported & sm.supported_mode_bit(c)]
            raise InputError(f"drive mode {mode!r} is not supported by the drive; it supports {names}")
        deadline = time.monotonic() + (timeout_s if timeout_s is not None else 2 * self.sdo_timeout_s)
        self.sdo_write(0x6060, 0, code, action=action)
        while True:
            display = self.sdo_read(0x6061, action=f"{action}: read mode display 0x6061")
            if display == code:
                return
            if time.monotonic() >= deadline:
                raise self._error(InstrumentTimeout, action, f"mode display shows {display}")
            time.sleep(0.005)

    def mode(self) -> str:
        code = self.sdo_read(0x6061, action="read mode display 0x6061")
        return next((name for name, c in sm.MODE_CODES.items() if c == code), f"code {code}")

    def _rated_torque_nm(self) -> float:
        """Motor rated torque 0x6076 (mN·m on the bus), read once per connection."""
        if self._rated_torque_cache_nm is None:
            self._rated_torque_cache_nm = self.sdo_read(
                0x6076, action="read motor rated torque 0x6076") / 1000.0
        return self._rated_torque_cache_nm

    def _checked_count(self, obj: ScaledObject, value_si, action: str) -> int:
        try:
            return obj.check_si(value_si)
        except ValueError as exc:
            raise self._error(InjectionRangeError, action, str(exc)) from None

    def set_current_command_a(self, current_a: float) -> None:
        """Peak phase-current command through the profile's object (shipped: 0x2100, mA), or
        without one through target torque 0x6071 in per mille of the rated current 0x6075;
        verified by read-back."""
        action = f"set current command {current_a!r} A"
        obj = self._current_command
        if obj is None:
            self._set_per_mille_of_rated_current(current_a, action)
            return
        count = self._checked_count(obj, current_a, action)
        self._write_verified(obj.index, count, action, subindex=obj.subindex)

    def _set_per_mille_of_rated_current(self, current_a: float, action: str) -> None:
        """0x6071 = current / rated current 0x6075 (mA) × 1000: CiA 402's per mille of the
        rated torque, the drive's own torque constant being 0x6076 / 0x6075."""
        rated_a = self.sdo_read(0x6075, action=f"{action}: read motor rated current 0x6075") / 1000.0
        self._write_per_mille(current_a, rated_a, "current command", "A (target torque 0x6071)",
                              action)

    def set_target_torque_nm(self, torque_nm: float) -> None:
        """Target torque 0x6071 in per mille of the rated torque 0x6076, verified by read-back."""
        action = f"set target torque {torque_nm!r} N·m"
        self._write_per_mille(torque_nm, self._rated_torque_nm(), "target torque", "N·m", action)

    def _write_per_mille(self, value: float, rated: float, what: str, unit: str,
                         action: str) -> None:
        """Target torque 0x6071 = value / rated × 1000, within the EDS limits, verified."""
        od = self._require_node(action).object_dictionary[0x6071]
        per_mille = round(value / rated * 1000.0) if math.isfinite(value) else None
        if per_mille is None or not od.min <= per_mille <= od.max:
            raise self._error(InjectionRangeError, action,
                              f"{what} must be in {od.min * rated / 1000:g}.."
                              f"{od.max * rated / 1000:g} {unit}")
        self._write_verified(0x6071, per_mille, action)

    def set_target_velocity_rpm(self, speed_rpm: float) -> None:
        """Target velocity 0x60FF in rpm (on the simulated bench: the dyno speed setpoint)."""
        action = f"set target velocity {speed_rpm!r} rpm"
        od = self._require_node(action).object_dictionary[0x60FF]
        value = round(speed_rpm) if math.isfinite(speed_rpm) else None
        if value is None or not od.min <= value <= od.max:
            raise self._error(InjectionRangeError, action, f"speed_rpm must be in {od.min}..{od.max}")
        self._write_verified(0x60FF, value, action)

    # -- fault injection --------------------------------------------------------------------
    def injection_limits(self) -> dict[str, tuple]:
        """(low, high, default) of every knob in SI units, from the EDS."""
        return {k: (o.low_si, o.high_si, o.default_si) for k, o in self._knobs.items()}

    def read_injections(self) -> dict[str, tuple]:
        """Every knob as the drive reads it back now: {knob: (value SI, default SI)}."""
        return {knob: (obj.to_si(self.sdo_read(obj.index, obj.subindex,
                                               action=f"read injection {knob}")),
                       obj.default_si) for knob, obj in self._knobs.items()}

    def set_injection(self, **knobs) -> None:
        """Write fault-injection knobs (SI units); all are range-checked before any is sent.

        A plan knob the drive's profile leaves out is not sent when the value asked is the one
        the drive runs at (``DriveProfile.value_si``); any other value is refused."""
        counts = {}
        for knob, value in knobs.items():
            action = f"set injection {knob}={value!r}"
            if knob not in self._knobs:
                self._check_absent_knob(knob, value)
                continue
            counts[knob] = self._checked_count(self._knobs[knob], value, action)
        for knob, count in counts.items():
            obj = self._knobs[knob]
            self._write_verified(obj.index, count,
                                 f"set injection {knob}={knobs[knob]!r} ({obj.address}={count})",
                                 subindex=obj.subindex)

    def _check_absent_knob(self, knob: str, value) -> None:
        if knob not in plan_knobs():
            raise InputError(f"unknown injection knob {knob!r}; known: {sorted(self._knobs)}")
        if self.profile.lacks(knob, value):
            raise InputError(f"the drive under test has no {knob} (drive profile "
                             f"{self.profile.name!r}); it runs at {self.profile.value_si(knob)!r}, "
                             f"the point asks {value!r}")

    def injection(self) -> dict:
        """Every knob read back from the drive, in SI units."""
        return {knob: obj.to_si(self.sdo_read(obj.index, obj.subindex,
                                              action=f"read injection {knob}"))
                for knob, obj in self._knobs.items()}

    def restore_injection_defaults(self) -> None:
        """Restore every knob as the profile says — its restore object (shipped: the "load"
        signature to 0x2000), else each knob's restore count written — then check every knob
        reads its restore value."""
        action = "restore injection defaults"
        restore = self.profile.restore
        if restore is not None:
            self.sdo_write(restore.index, restore.subindex, restore.value, action=action)
        else:
            for knob, obj in self._knobs.items():
                self.sdo_write(obj.index, obj.subindex, obj.default_count,
                               action=f"{action}: write {knob}")
        for knob, obj in self._knobs.items():
            count = self.sdo_read(obj.index, obj.subindex, action=f"{action}: read back {knob}")
            if count != obj.default_count:
                raise self._error(ProtocolError, action,
                                  f"{knob} reads {obj.to_si(count)!r}, default is {obj.default_si!r}")

    # -- actual values and health -----------------------------------------------------------
    def actual(self, max_age_s: float | None = None) -> dict:
        """Latest PDO-fed actual values: torque_nm, velocity_rpm, position_counts, state, age_s."""
        max_age_s = max_age_s if max_age_s is not None else max(0.1, 5 * self.tpdo_event_timer_ms / 1000)
        rated_torque_nm = self._rated_torque_nm()
        with self._tpdo_update:
            needed = (0x6041, 0x6077, 0x606C, 0x6064)
            missing = [f"0x{i:04X}" for i in needed if i not in self._tpdo_time]
            if missing:
                raise self._error(InstrumentTimeout, "read actual values", f"no TPDO yet for {missing}")
            age_s = time.monotonic() - min(self._tpdo_time[i] for i in needed)
            values = {i: self._tpdo_values[i] for i in needed}
        if age_s > max_age_s:
            raise self._error(InstrumentTimeout, "read actual values",
                              f"newest TPDOs are {age_s:.3f} s old (limit {max_age_s} s)")
        return {
            "torque_nm": values[0x6077] / 1000.0 * rated_torque_nm,
            "velocity_rpm": float(values[0x606C]),
            "position_counts": int(values[0x6064]),
            "state": sm.state_from_statusword(values[0x6041]),
            "age_s": age_s,
        }

    def check_health(self, *, synchronise: bool = False) -> None:
        """Raise HeartbeatLost if the heartbeat is older than the timeout, DeviceFault on EMCY or
        a FAULT / FAULT REACTION ACTIVE statusword.

        ``synchronise``: after the checks of what has been received, read the statusword over
        SDO and check again. One node's frames keep their order on CAN and the bus thread hands
        them over in that order, so every EMCY the drive sent before its reply has been seen when
        the reply arrives: a fault raised at the end of a capture fails the check that follows it
        instead of the next point's. What was already known (an EMCY, a lost heartbeat) is
        reported before the SDO read is tried, so a silent drive is named for what it did."""
        action = "check health"
        self._check_received(action)
        if synchronise:
            word = self.sdo_read(0x6041, action=f"{action}: read statusword 0x6041")
            self._check_received(action)
            self._check_statusword(word, action)

    def _check_received(self, action: str) -> None:
        """The health check on what the bus thread has received: connection, heartbeat, EMCY,
        NMT state, the latest fresh statusword TPDO."""
        if self._connected_at is None:
            raise self._error(HeartbeatLost, action, f"not connected to node {self.node_id}")
        if self.bus_lost() is not None:     # TransportLost, whatever the last heartbeat's age
            raise self._error(HeartbeatLost, action, "CAN bus lost")
        self._check_heartbeat(action)
        emcy = self._emcy
        if emcy is not None:
            raise self._error(DeviceFault, action,
                              f"EMCY 0x{emcy.code:04X} ({emcy.get_desc() or 'manufacturer'}), "
                              f"error register 0x{emcy.register:02X}, data {bytes(emcy.data)!r}; "
                              "call fault_reset()")
        if self._heartbeat_state is not None and self._heartbeat_state != NMT_OPERATIONAL:
            raise self._error(DeviceFault, action,
                              f"node {self.node_id} left NMT OPERATIONAL (heartbeat state "
                              f"{self._heartbeat_state})")
        self._check_statusword(self._fresh_tpdo(0x6041), action)

    def _check_statusword(self, word: int | None, action: str) -> None:
        state = None if word is None else sm.state_from_statusword(word)
        if state in (sm.FAULT, sm.FAULT_REACTION_ACTIVE):
            raise self._error(DeviceFault, action, f"drive statusword shows {state}")

