"""PDOs of the simulated drive node, built from its own dictionary (so a master's remap counts).

canopen 2.4.x's ``LocalNode`` does not apply received RPDOs, never sends TPDOs and keeps the
mapping it was created with. Here every PDO's configuration is re-read from the node's data store
whenever the master writes a PDO communication or mapping object, RPDO contents are written into
the dictionary through the node's normal write path, and TPDOs are sent by
``TpdoScheduler`` (event timer, on change of mapped objects, or every n-th SYNC).
"""

from __future__ import annotations

import logging
import threading
import time
from dataclasses import dataclass

from canopen.sdo import SdoAbortedError

logger = logging.getLogger(__name__)

RPDO_COMM, RPDO_MAP, TPDO_COMM, TPDO_MAP = 0x1400, 0x1600, 0x1800, 0x1A00
PDO_COUNT = 4
COB_ID_INVALID = 0x80000000
SYNC_COB_ID = 0x080          # default of 0x1005 (CiA 301)
COB_ID_SYNC_INDEX = 0x1005


def is_pdo_config_index(index: int) -> bool:
    return 0x1400 <= index < 0x1400 + PDO_COUNT or 0x1600 <= index < 0x1600 + PDO_COUNT \
        or 0x1800 <= index < 0x1800 + PDO_COUNT or 0x1A00 <= index < 0x1A00 + PDO_COUNT


@dataclass(frozen=True)
class PdoConfig:
    """One PDO's communication and mapping parameters as currently stored in the node."""

    number: int                           # 1..4
    cob_id: int
    enabled: bool
    transmission_type: int
    event_timer_ms: int
    entries: tuple[tuple[int, int, int], ...]  # (index, subindex, length in bits)

    @property
    def length_bytes(self) -> int:
        return sum(bits for _, _, bits in self.entries) // 8


def read_pdo_config(node, comm_index: int, map_index: int, number: int) -> PdoConfig:
    """Read one PDO's parameters from ``node``'s data store (the values the master wrote)."""
    cob_raw = node.stored_value(comm_index, 1)
    transmission_type = node.stored_value(comm_index, 2)
    try:
        event_timer_ms = node.stored_value(comm_index, 5)
    except SdoAbortedError:  # RPDO communication records have no event timer (sub-index 5)
        event_timer_ms = 0
    count = node.stored_value(map_index, 0)
    entries = []
    for subindex in range(1, count + 1):
        value = node.stored_value(map_index, subindex)
        index, sub, bits = value >> 16, (value >> 8) & 0xFF, value & 0xFF
        if index and bits:
            entries.append((index, sub, bits))
    return PdoConfig(number=number, cob_id=cob_raw & 0x7FF, enabled=not cob_raw & COB_ID_INVALID,
                     transmission_type=transmission_type, event_timer_ms=event_timer_ms or 0,
                     entries=tuple(entries))


def validate_mapping_entry(node, value: int) -> bool:
    """True if a mapping entry names an existing PDO-mappable object of that exact size."""
    index, sub, bits = value >> 16, (value >> 8) & 0xFF, value & 0xFF
    if value == 0:
        return True
    try:
        obj = node.find_object(index, sub)
    except SdoAbortedError:  # no such object
        return False
    return bool(obj.pdo_mappable) and len(obj) == bits


class PdoEngine:
    """RPDO reception and TPDO transmission for a ``DriveLocalNode`` on a canopen network."""

    MIN_TICK_S = 0.001
    MAX_TICK_S = 0.005

    def __init__(self, node, network, *, is_operational) -> None:
        self._node = node
        self._network = network
        self._is_operational = is_operational
        self._tick_s = self.MAX_TICK_S
        self._lock = threading.RLock()
        self._rpdos: list[PdoConfig] = []
        self._tpdos: list[PdoConfig] = []
        self._next_due: dict[int, float] = {}
        self._last_sent: dict[int, bytes] = {}
        self._sync_count = 0
        self._sync_cob_id = SYNC_COB_ID
        self._changed = threading.Event()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.tpdos_sent = 0
        self.rpdos_applied = 0

    # -- configuration ----------------------------------------------------------------------
    def reload(self) -> None:
        """Re-read all PDO configurations from the node (after any PDO object write)."""
        with self._lock:
            for config in self._rpdos:
                if config.enabled:
                    self._network.unsubscribe(config.cob_id, self._on_rpdo)
            self._rpdos = [read_pdo_config(self._node, RPDO_COMM + n, RPDO_MAP + n, n + 1)
                           for n in range(PDO_COUNT)]
            self._tpdos = [read_pdo_config(self._node, TPDO_COMM + n, TPDO_MAP + n, n + 1)
                           for n in range(PDO_COUNT)]
            for config in self._rpdos:
                if config.enabled:
                    self._network.subscribe(config.cob_id, self._on_rpdo)
            self._next_due.clear()
            self._last_sent.clear()
            timers_s = [c.event_timer_ms / 1000 for c in self._tpdos if c.enabled and c.event_timer_ms]
            # scheduler tick: half the shortest event timer, within 1..5 ms
            self._tick_s = min(self.MAX_TICK_S, max(self.MIN_TICK_S, min(timers_s, default=1) / 2))

    @property
    def tpdo_configs(self) -> list[PdoConfig]:
        with self._lock:
            return list(self._tpdos)

    # -- RPDO -------------------------------------------------------------------------------
    def _on_rpdo(self, can_id: int, data: bytes, timestamp: float) -> None:
        if not self._is_operational():
            return
        with self._lock:
            config = next((c for c in self._rpdos if c.enabled and c.cob_id == can_id), None)
        if config is None or len(data) < config.length_bytes:
            logger.warning("RPDO 0x%03X with %d bytes does not match its mapping", can_id, len(data))
            return
        offset = 0
        for index, subindex, bits in config.entries:
            chunk = bytes(data[offset:offset + bits // 8])
            offset += bits // 8
            try:
                self._node.set_data(index, subindex, chunk, check_writable=True)
            except Exception as exc:  # a PDO has no answer channel; the value is dropped
                logger.warning("RPDO%d write 0x%04X:%02X rejected: %s", config.number, index,
                               subindex, exc)
        self.rpdos_applied += 1

    # -- TPDO -------------------------------------------------------------------------------
    def notify_change(self) -> None:
        """A mapped value may have changed: event-driven TPDOs go out now, not at the timer."""
        self._changed.set()

    def on_sync(self, can_id: int, data: bytes, timestamp: float) -> None:
        if not self._is_operational():
            return
        with self._lock:
            self._sync_count += 1
            for config in self._tpdos:
                if config.enabled and config.transmission_type <= 240:
                    every = max(1, config.transmission_type)
                    if self._sync_count % every == 0:
                        self._send(config)

    def _payload(self, config: PdoConfig) -> bytes:
        parts = []
        for index, subindex, bits in config.entries:
            parts.append(self._node.get_data(index, subindex)[:bits // 8])
        return b"".join(parts)

    def _send(self, config: PdoConfig, payload: bytes | None = None) -> None:
        payload = self._payload(config) if payload is None else payload
        self._network.send_message(config.cob_id, payload)
        self._last_sent[config.number] = payload
        self.tpdos_sent += 1

    def send_event_driven(self) -> None:
        """Send the asynchronous TPDOs (type 254/255) whose event timer expired or data changed."""
        if not self._is_operational():
            return
        now = time.monotonic()
        with self._lock:
            for config in self._tpdos:
                if not config.enabled or config.transmission_type < 254 or not config.entries:
                    continue
                payload = self._payload(config)
                due = config.event_timer_ms > 0 and now >= self._next_due.get(config.number, 0.0)
                changed = payload != self._last_sent.get(config.number)
                if due or changed:
                    self._send(config, payload)
                    if config.event_timer_ms > 0:
                        self._next_due[config.number] = now + config.event_timer_ms / 1000.0

    def _run(self) -> None:
        while not self._stop.is_set():
            self._changed.wait(self._tick_s)
            self._changed.clear()
            try:
                self.send_event_driven()
            except Exception:  # keep the node alive; a broken bus shows up as missing PDOs
                logger.exception("TPDO transmission failed")

    def set_sync_cob_id(self, cob_id_entry: int) -> None:
        """Consume SYNC on the COB-ID in a 0x1005 value (bits 0..10; bit 30 "generate" unused)."""
        cob_id = cob_id_entry & 0x7FF
        with self._lock:
            if self._thread is not None:
                self._network.unsubscribe(self._sync_cob_id, self.on_sync)
                self._network.subscribe(cob_id, self.on_sync)
            self._sync_cob_id = cob_id

    def start(self) -> None:
        self._network.subscribe(self._sync_cob_id, self.on_sync)
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name="sim-drive-tpdo", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=1.0)
            self._thread = None
        self._network.unsubscribe(self._sync_cob_id, self.on_sync)
        with self._lock:
            for config in self._rpdos:
                if config.enabled:
                    self._network.unsubscribe(config.cob_id, self._on_rpdo)
