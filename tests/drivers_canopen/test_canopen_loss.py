"""A drive whose remote CAN bus goes away (issue 11 item 3, design §6): the simulated drive is
served by python-can-remote from its own process on 127.0.0.1, which is killed (SIGKILL, as
``kill -9`` of ``hil sim-bench``) while the real driver talks to it. Every failure is
``TransportLost`` naming the instrument and the step, with the operating system's reason and the
original error as its cause; the notifier and periodic-sender threads neither die with a traceback
nor log one, and closing the driver afterwards is quick and quiet.
"""

from __future__ import annotations

import json
import logging
import re
import signal
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

import pytest

from ripple_hil_drivers.canopen_transport import CanBusSettings
from ripple_hil_drivers.cia402 import Cia402Drive
from ripple_hil_drivers.errors import TransportLost

pytestmark = [pytest.mark.integration, pytest.mark.timeout(60)]

ROOT = Path(__file__).resolve().parents[2]
#: The simulated drive behind a python-can-remote server, in a process of its own; prints its
#: bench-file table and stops when stdin closes.
SERVER = textwrap.dedent("""
    import json, sys
    from hil.sim import DriveTwin
    from ripple_hil_drivers.simulated.can_remote_server import serve_simulated_drive
    server = serve_simulated_drive(DriveTwin(seed=0), node_id=5)
    print(json.dumps(server.bench_table()), flush=True)
    sys.stdin.read()
    server.stop()
""")
#: What the OS or the websocket says when the link to the server breaks.
LINK_REASON = re.compile(r"\[Errno \d+\] \w|WebsocketClosed")
SDO_TIMEOUT_S = 2.0


@pytest.fixture
def server():
    process = subprocess.Popen([sys.executable, "-c", SERVER], cwd=ROOT, stdin=subprocess.PIPE,
                               stdout=subprocess.PIPE, text=True)
    table = json.loads(process.stdout.readline())
    yield process, CanBusSettings(interface="remote", channel=table["channel"],
                                  bitrate=table["bitrate"])
    if process.poll() is None:
        process.stdin.close()
        process.wait(timeout=10)


@pytest.fixture
def thread_errors(monkeypatch):
    """Exceptions that end a background thread (each would print a traceback)."""
    seen = []
    monkeypatch.setattr(threading, "excepthook", lambda args: seen.append(args.exc_value))
    return seen


def test_server_killed_mid_sdo_traffic(server, thread_errors, caplog):
    process, settings = server
    drive = Cia402Drive(settings, node_id=5, sdo_timeout_s=SDO_TIMEOUT_S, heartbeat_timeout_s=0.5,
                        instrument_name="drive-x").connect()
    try:
        drive.enable()
        killer = threading.Timer(0.3, lambda: process.send_signal(signal.SIGKILL))
        killer.start()
        reads = 0
        with caplog.at_level(logging.DEBUG), pytest.raises(TransportLost) as caught:
            deadline = time.monotonic() + 10
            while time.monotonic() < deadline:       # SDO uploads until the link breaks
                drive.injection()
                reads += 1
        killer.join()
        error = caught.value
        assert reads >= 1                             # the traffic ran before the kill
        assert error.instrument == "drive-x" and error.action.startswith("read injection ")
        assert str(error) == f"drive-x: {error.action}: CAN bus lost: {error.reason}"
        assert LINK_REASON.search(error.reason), error.reason
        assert error.__cause__ is not None

        # later steps (the safety guard's) fail at once with the same typed error, not after
        # an SDO timeout
        for step, action in ((lambda: drive.statusword, "read statusword"),
                             (drive.check_health, "check health"),
                             (drive.disable, "")):
            started = time.monotonic()
            with pytest.raises(TransportLost) as later:
                step()
            assert time.monotonic() - started < SDO_TIMEOUT_S / 2, action
            assert later.value.instrument == "drive-x" and action in later.value.action
            assert later.value.reason == error.reason
        time.sleep(0.3)                               # the heartbeat sender's next periods
    finally:
        started = time.monotonic()
        drive.close()
        closing_s = time.monotonic() - started
    assert closing_s < 2.0
    assert thread_errors == []
    logged = [r for r in caplog.records if r.levelno >= logging.WARNING and r.exc_info
              and r.threadName != "MainThread"]            # a traceback on the terminal
    assert logged == [], [f"{r.threadName}: {r.getMessage()}" for r in logged]
