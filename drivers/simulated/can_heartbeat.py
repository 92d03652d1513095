"""CiA 301 heartbeat consumer of the simulated drive (object 0x1016), for master-loss detection.

Each 0x1016 sub-entry ``(producer node id << 16) | consumer time [ms]`` with a non-zero id and
time monitors the heartbeat frames (COB-ID 0x700 + id) of that producer. Per CiA 301 monitoring
starts at the first heartbeat received; when no heartbeat follows within the consumer time the
entry reports one timeout (``on_timeout(producer_id)``) and waits for the next heartbeat, which
re-arms it and reports ``on_resumed(producer_id)``.

canopen 2.4.x's ``LocalNode`` has no heartbeat consumer; this one subscribes to the node's
``canopen.Network`` and checks the deadlines in its own daemon thread.
"""

from __future__ import annotations

import logging
import threading
import time
from dataclasses import dataclass
from typing import Callable

from canopen.sdo import SdoAbortedError

logger = logging.getLogger(__name__)

CONSUMER_HEARTBEAT_INDEX = 0x1016
HEARTBEAT_COB_BASE = 0x700
ABORT_PARAMETER_INCOMPATIBLE = 0x06040043


@dataclass(frozen=True)
class ConsumerEntry:
    """One decoded 0x1016 sub-entry (CiA 301: bits 16..23 node id, 0..15 time in ms)."""

    producer_id: int
    time_ms: int

    @classmethod
    def decode(cls, raw: int) -> "ConsumerEntry":
        return cls(producer_id=(raw >> 16) & 0xFF, time_ms=raw & 0xFFFF)

    @property
    def active(self) -> bool:
        return self.producer_id != 0 and self.time_ms != 0


def consumer_entries(node) -> list[ConsumerEntry]:
    """The active 0x1016 entries stored in ``node`` (a ``DriveLocalNode``)."""
    count = node.stored_value(CONSUMER_HEARTBEAT_INDEX, 0)
    entries = [ConsumerEntry.decode(node.stored_value(CONSUMER_HEARTBEAT_INDEX, sub))
               for sub in range(1, count + 1)]
    return [entry for entry in entries if entry.active]


def check_consumer_write(node, subindex: int, raw: int) -> None:
    """SDO abort 0x06040043 if the write would monitor one producer in two sub-entries (CiA 301)."""
    new = ConsumerEntry.decode(raw)
    if not new.active:
        return
    count = node.stored_value(CONSUMER_HEARTBEAT_INDEX, 0)
    for sub in range(1, count + 1):
        if sub == subindex:
            continue
        other = ConsumerEntry.decode(node.stored_value(CONSUMER_HEARTBEAT_INDEX, sub))
        if other.active and other.producer_id == new.producer_id:
            raise SdoAbortedError(ABORT_PARAMETER_INCOMPATIBLE)


class _Monitor:
    """Deadline state of one monitored producer."""

    def __init__(self, entry: ConsumerEntry) -> None:
        self.entry = entry
        self.last_seen: float | None = None   # None: waiting for the first heartbeat
        self.timed_out = False

    @property
    def deadline(self) -> float | None:
        return None if self.last_seen is None else self.last_seen + self.entry.time_ms / 1000.0


class HeartbeatConsumer:
    """Watches the producers listed in a node's 0x1016 and calls back on timeout and on resume.

    Callbacks run in the consumer's own thread (timeouts) or the network's receive thread
    (resume); they must not block for long.
    """

    def __init__(self, network, *, on_timeout: Callable[[int], None],
                 on_resumed: Callable[[int], None]) -> None:
        self._network = network
        self._on_timeout = on_timeout
        self._on_resumed = on_resumed
        self._monitors: dict[int, _Monitor] = {}
        self._condition = threading.Condition()
        self._stopping = False
        self._thread: threading.Thread | None = None

    @property
    def entries(self) -> list[ConsumerEntry]:
        with self._condition:
            return [monitor.entry for monitor in self._monitors.values()]

    def configure(self, entries: list[ConsumerEntry]) -> None:
        """Monitor exactly ``entries``; an unchanged entry keeps its state, a changed one restarts."""
        with self._condition:
            wanted = {entry.producer_id: entry for entry in entries}
            for producer_id in list(self._monitors):
                if wanted.get(producer_id) != self._monitors[producer_id].entry:
                    self._network.unsubscribe(HEARTBEAT_COB_BASE + producer_id, self._on_frame)
                    del self._monitors[producer_id]
            for producer_id, entry in wanted.items():
                if producer_id not in self._monitors:
                    self._monitors[producer_id] = _Monitor(entry)
                    self._network.subscribe(HEARTBEAT_COB_BASE + producer_id, self._on_frame)
            self._condition.notify_all()

    def _on_frame(self, can_id: int, data: bytes, timestamp: float) -> None:
        producer_id = can_id - HEARTBEAT_COB_BASE
        with self._condition:
            monitor = self._monitors.get(producer_id)
            if monitor is None:
                return
            monitor.last_seen = time.monotonic()
            resumed, monitor.timed_out = monitor.timed_out, False
            self._condition.notify_all()
        if resumed:
            logger.info("heartbeat consumer: producer %d is back", producer_id)
            self._on_resumed(producer_id)

    def _expired(self) -> tuple[list[int], float | None]:
        """Producers whose deadline passed (now disarmed) and the time to the next deadline."""
        now = time.monotonic()
        expired, wait_s = [], None
        for producer_id, monitor in self._monitors.items():
            deadline = monitor.deadline
            if deadline is None:
                continue
            if deadline <= now:
                monitor.last_seen = None   # CiA 301: re-armed by the next heartbeat
                monitor.timed_out = True
                expired.append(producer_id)
            else:
                wait_s = deadline - now if wait_s is None else min(wait_s, deadline - now)
        return expired, wait_s

    def _run(self) -> None:
        while True:
            with self._condition:
                if self._stopping:
                    return
                expired, wait_s = self._expired()
                if not expired:
                    self._condition.wait(wait_s)
                    continue
            for producer_id in expired:
                logger.warning("heartbeat consumer: no heartbeat from node %d", producer_id)
                try:
                    self._on_timeout(producer_id)
                except Exception:  # noqa: BLE001 - keep monitoring the other producers
                    logger.exception("heartbeat consumer: timeout handler failed")

    def start(self) -> None:
        self._thread = threading.Thread(target=self._run, name="sim-drive-heartbeat-consumer",
                                        daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self.configure([])
        with self._condition:
            self._stopping = True
            self._condition.notify_all()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
