"""Serve the simulated drive to other processes over TCP loopback (python-can-remote).

``hil sim-bench`` runs in its own process; a test run in another process reaches the simulated
drive with only the bench-file settings ``interface = "remote"``, ``channel =
"ws://127.0.0.1:<port>/"``. Inside the serving process the drive node sits on a private python-can
``virtual`` channel and a ``BusServer`` bridges TCP clients onto that channel.
"""

from __future__ import annotations

import logging
import os
import uuid

import can_remote.server

from ripple_hil_drivers.canopen_transport import BusServer, CanBusSettings
from ripple_hil_drivers.simulated.drive_node import SimulatedDrive

log = logging.getLogger(__name__)


def use_client_safe_sessions() -> None:
    """End a python-can-remote client session quietly when its client goes away.

    The library's per-client send thread (``RemoteServerProtocol._send_to_client``) dies with a
    ``BrokenPipeError`` traceback when a client process is killed mid-session (issue 22.8) and
    never shuts its bus down, so a long-lived ``hil sim-bench`` would keep one more virtual bus
    queueing every CAN frame per dead client. Wrapped here (once per process; the library
    creates the session class itself, so it cannot be handed a subclass): a connection error
    (``OSError``) in that thread logs one line, stops the session and shuts its bus down.
    """
    protocol = can_remote.server.RemoteServerProtocol
    if getattr(protocol._send_to_client, "client_safe", False):
        return
    send_to_client = protocol._send_to_client

    def _send_to_client(self):
        try:
            send_to_client(self)
        except OSError as exc:
            log.info("CAN remote client gone (%s): session closed", exc)
            self.running = False
            self.bus.shutdown()

    _send_to_client.client_safe = True
    protocol._send_to_client = _send_to_client


class RemoteSimulatedDrive:
    """A ``SimulatedDrive`` plus a loopback CAN server; ``client_settings`` go in the bench file."""

    def __init__(self, twin, node_id: int = 5, *, host: str = "127.0.0.1", port: int = 0,
                 bitrate: int = 500_000, **drive_options) -> None:
        channel = f"sim-bench-{os.getpid()}-{uuid.uuid4().hex[:8]}"
        self.local_settings = CanBusSettings(interface="virtual", channel=channel, bitrate=bitrate)
        self.drive = SimulatedDrive(twin, self.local_settings, node_id, **drive_options)
        use_client_safe_sessions()
        self.server = BusServer(self.local_settings, host=host, port=port)
        self.node_id = node_id

    @property
    def client_settings(self) -> CanBusSettings:
        """What the second process passes to ``Cia402Drive`` (bench file ``[drive]``)."""
        return self.server.client_settings

    def bench_table(self) -> dict:
        """The ``[drive]`` table of a bench file pointing at this server."""
        settings = self.client_settings
        return {"interface": settings.interface, "channel": settings.channel,
                "bitrate": settings.bitrate, "node_id": self.node_id}

    def start(self) -> "RemoteSimulatedDrive":
        self.drive.start()
        try:
            self.server.start()
        except BaseException:
            self.drive.stop()
            raise
        return self

    def stop(self) -> None:
        try:
            self.server.stop()
        finally:
            self.drive.stop()

    def __enter__(self) -> "RemoteSimulatedDrive":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()


def serve_simulated_drive(twin, node_id: int = 5, *, host: str = "127.0.0.1",
                          port: int = 0, **drive_options) -> RemoteSimulatedDrive:
    """Start the simulated drive behind a loopback CAN server and return the running handle."""
    return RemoteSimulatedDrive(twin, node_id, host=host, port=port, **drive_options).start()
