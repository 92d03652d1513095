"""CAN bus settings from the bench file, opening a python-can bus, and a loopback bus server.

Any adapter python-can supports works: ``CanBusSettings(interface, channel, bitrate)`` is passed to
``can.Bus``. Two transports matter for the simulated bench:

* ``virtual`` — python-can's in-process bus (one process; tests).
* ``remote`` — python-can-remote (``can_remote``): a websocket bridge on TCP. ``serve_bus`` runs
  its server on 127.0.0.1 in front of a ``virtual`` channel, so a second process reaches the
  simulated drive with only ``interface="remote", channel="ws://127.0.0.1:<port>/"``.

python-can-remote 0.3.0 with python-can 4.6: plain frames and ``send_periodic`` start/stop work,
but its ``CyclicSendTask.modify_data`` raises TypeError (``super(self)``), which canopen calls when
a periodic frame's data change (heartbeat producer after an NMT change, SYNC counter). ``open_bus``
therefore gives the remote bus python-can's own thread-based periodic sender instead.

A lost link (issue 11: the ``hil sim-bench`` process killed, the server gone): python-can-remote
lets raw ``BrokenPipeError`` / ``ConnectionResetError`` / ``WebsocketClosed`` out of ``send`` and
``recv``, which kills canopen's notifier thread and the periodic sender threads with printed
tracebacks. ``open_bus``'s remote bus raises ``can.CanOperationError`` instead (python-can's
contract) and keeps the first such error in ``lost_error``; its periodic frames are then dropped
quietly; :class:`BusLossWatch` keeps a notifier thread's receive error (any interface) for the
driver, which raises ``TransportLost`` from it.
"""

from __future__ import annotations

import contextlib
import logging
import threading
import time
from dataclasses import dataclass

import can
from can.broadcastmanager import ThreadBasedCyclicSendTask

from ripple_hil_drivers.errors import transport_reason
from hil.errors import InputError

logger = logging.getLogger(__name__)

NOTIFIER_CYCLE_S = 0.05
"""Receive timeout of a canopen network's notifier thread: closing waits at most this long."""


@dataclass(frozen=True)
class CanBusSettings:
    """python-can bus settings as written in the bench file's ``[drive]`` table."""

    interface: str = "virtual"
    channel: str = "hil"
    bitrate: int = 500_000

    def __post_init__(self) -> None:
        if not isinstance(self.interface, str) or not self.interface:
            raise InputError(f"drive.interface must be a python-can interface name, "
                             f"got {self.interface!r}")
        if not isinstance(self.bitrate, int) or not 10_000 <= self.bitrate <= 1_000_000:
            raise InputError(f"drive.bitrate={self.bitrate!r} is outside 10000..1000000 bit/s")

    def bus_kwargs(self) -> dict:
        return {"interface": self.interface, "channel": self.channel, "bitrate": self.bitrate}


def _remote_bus_class():
    from can_remote.client import RemoteBus
    from can_remote.websocket import WebsocketClosed

    link_errors = (OSError, WebsocketClosed)

    class RemoteBusWithThreadedPeriodic(RemoteBus):
        """RemoteBus whose periodic frames are sent by python-can's threaded task (modifiable),
        and whose lost link raises ``can.CanOperationError`` (first error kept in
        ``lost_error``) instead of raw socket errors."""

        lost_error: BaseException | None = None

        def _lost(self, error: BaseException) -> can.CanOperationError:
            if self.lost_error is None:
                self.lost_error = error
            return can.CanOperationError(f"remote CAN bus {self.channel} lost: "
                                         f"{transport_reason(self.lost_error)}")

        def send(self, msg, timeout=None):
            if self.lost_error is not None:
                raise self._lost(self.lost_error) from self.lost_error
            try:
                super().send(msg, timeout)
            except link_errors as exc:
                raise self._lost(exc) from exc

        def recv(self, timeout=None):
            try:
                return super().recv(timeout)
            except link_errors as exc:
                raise self._lost(exc) from exc

        def shutdown(self):
            if self.lost_error is None:
                try:
                    super().shutdown()          # closing handshake with the server
                    return
                except link_errors as exc:
                    self._lost(exc)
            with contextlib.suppress(OSError):
                self.socket.close()
            can.BusABC.shutdown(self)           # periodic tasks stopped, marked shut down

        def _send_periodic_internal(self, msgs, period, duration=None, autostart=True,
                                    modifier_callback=None):
            if not hasattr(self, "_lock_send_periodic"):
                self._lock_send_periodic = threading.Lock()
            return ThreadBasedCyclicSendTask(_PeriodicSender(self), self._lock_send_periodic,
                                             msgs, period, duration, autostart=autostart,
                                             modifier_callback=modifier_callback)

    return RemoteBusWithThreadedPeriodic


class _PeriodicSender:
    """What a remote bus's periodic task sends through: the bus, except that once its link is
    lost the frames are dropped quietly (the loss is kept on the bus and raised by the next
    foreground call) instead of the task thread logging and raising a traceback."""

    def __init__(self, bus) -> None:
        self._bus = bus

    def send(self, msg, timeout=None) -> None:
        try:
            self._bus.send(msg, timeout)
        except can.CanOperationError:
            if self._bus.lost_error is None:
                raise


class BusLossWatch(can.Listener):
    """A notifier listener keeping the first receive error of the bus (the interface or the
    link to a remote bus is gone) instead of letting it end the notifier thread with a printed
    traceback. Each further error waits one notifier cycle, so a dead bus is not polled in a
    tight loop. ``lost(bus)`` is the error that broke the link (receive or send), or None."""

    def __init__(self) -> None:
        self.error: BaseException | None = None

    def on_message_received(self, msg: can.Message) -> None:
        pass

    def on_error(self, exc: Exception) -> None:
        if self.error is None:
            self.error = exc
            logger.debug("CAN receive failed; the bus is lost", exc_info=exc)
        time.sleep(NOTIFIER_CYCLE_S)

    def lost(self, bus) -> BaseException | None:
        return self.error or getattr(bus, "lost_error", None)


def open_bus(settings: CanBusSettings) -> can.BusABC:
    """Open the bus described by ``settings`` (python-can raises CanError if it cannot)."""
    if settings.interface == "remote":
        return _remote_bus_class()(channel=settings.channel, bitrate=settings.bitrate)
    return can.Bus(**settings.bus_kwargs())


class _QuietServerMixin:
    def handle_error(self, request, client_address) -> None:
        # A client closing its websocket ends the HTTP keep-alive loop with a broken pipe.
        logger.debug("CAN remote server: connection from %s ended with an error", client_address,
                     exc_info=True)


class BusServer:
    """A python-can-remote server on 127.0.0.1 bridging TCP clients onto a local bus channel.

    ``settings`` is the server-side bus (normally ``virtual`` with the channel the simulated
    drive uses). ``client_settings`` is what a second process puts in its bench file.
    """

    def __init__(self, settings: CanBusSettings, *, host: str = "127.0.0.1", port: int = 0):
        from can_remote.server import RemoteServer

        server_class = type("QuietRemoteServer", (_QuietServerMixin, RemoteServer), {})
        self._server = server_class(host=host, port=port, **settings.bus_kwargs())
        self.host = host
        self.port = self._server.server_port
        self._bitrate = settings.bitrate
        self._thread = threading.Thread(target=self._server.serve_forever, kwargs={"poll_interval": 0.1},
                                        name=f"can-remote-server:{self.port}", daemon=True)

    @property
    def client_settings(self) -> CanBusSettings:
        return CanBusSettings(interface="remote", channel=f"ws://{self.host}:{self.port}/",
                              bitrate=self._bitrate)

    def start(self) -> "BusServer":
        self._thread.start()
        return self

    def stop(self) -> None:
        self._server.shutdown()
        self._server.server_close()
        self._thread.join(timeout=2.0)

    def __enter__(self) -> "BusServer":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()

