"""A DAQ that goes away mid-capture (issue 11 item 3, design §6): the simulated Modbus TCP DAQ runs
in its own process on 127.0.0.1 and is killed (SIGKILL, as ``kill -9`` of ``hil sim-bench``) while
the real driver is reading its buffer (pipelined reads) or polling its state (pymodbus requests).
Every failure is ``TransportLost`` naming the instrument and the step, with the operating system's
reason in the message and the original error as its cause; no raw socket error escapes.
"""

from __future__ import annotations

import logging
import re
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from ripple_hil_drivers import modbus_pipeline
from ripple_hil_drivers.errors import TransportLost
from ripple_hil_drivers.modbus_daq import ModbusDaq, ModbusTcpSettings

pytestmark = [pytest.mark.integration, pytest.mark.timeout(60)]

ROOT = Path(__file__).resolve().parents[2]
#: The simulated DAQ in a process of its own; it prints its port and stops when stdin closes.
SERVER = textwrap.dedent(f"""
    import sys
    sys.path.insert(0, {str(Path(__file__).parent)!r})
    from daq_twin import make_twin
    from ripple_hil_drivers.simulated.modbus_daq_server import SimulatedDaq
    server = SimulatedDaq(make_twin()).start()
    print(server.address[1], flush=True)
    sys.stdin.read()
    server.stop()
""")
#: What the OS or the peer says when a link breaks: an errno, or the server closing it.
LINK_REASON = re.compile(r"\[Errno \d+\] \w|closed")


class DaqProcess:
    """The simulated DAQ server process; ``kill()`` is SIGKILL (no goodbye on the socket)."""

    def __init__(self) -> None:
        self.process = subprocess.Popen([sys.executable, "-c", SERVER], cwd=ROOT,
                                        stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        line = self.process.stdout.readline()
        assert line.strip().isdigit(), f"simulated DAQ did not start: {line!r}"
        self.port = int(line)

    def kill(self) -> None:
        self.process.send_signal(signal.SIGKILL)
        self.process.wait(timeout=10)

    def stop(self) -> None:
        if self.process.poll() is None:
            self.process.stdin.close()
            try:
                self.process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()


@pytest.fixture
def server():
    process = DaqProcess()
    yield process
    process.stop()


def assert_lost(error: TransportLost, instrument: str, action: str) -> None:
    assert error.instrument == instrument and action in error.action, error
    assert str(error).startswith(f"{instrument}: {error.action}: ")
    assert LINK_REASON.search(error.reason), error.reason
    assert error.reason in str(error)
    assert error.__cause__ is not None            # raised from the original error


def test_killed_mid_pipelined_buffer_read(server, monkeypatch, caplog):
    """Killed after the first answers of the pipelined readout: the driver retries once (the
    DAQ keeps its buffer), cannot reconnect, and says so with the OS reason."""
    receive = modbus_pipeline._receive_some
    calls = []

    def receive_then_kill(sock, deadline):
        calls.append(1)
        if len(calls) == 2:
            server.kill()
        return receive(sock, deadline)

    monkeypatch.setattr(modbus_pipeline, "_receive_some", receive_then_kill)
    daq = ModbusDaq(ModbusTcpSettings("127.0.0.1", server.port), timeout_s=1.0,
                    instrument_name="daq-a").connect()
    try:
        with caplog.at_level(logging.WARNING, logger="ripple_hil_drivers.modbus_daq"), \
                pytest.raises(TransportLost) as caught:
            daq.capture(0.2, 20000.0)
    finally:
        daq.close()
    assert len(calls) >= 2                        # the kill happened inside the buffer read
    assert_lost(caught.value, "daq-a", "")
    assert f"cannot reconnect to 127.0.0.1:{server.port}" in str(caught.value)
    assert "Connection refused" in caught.value.reason
    first = [r.getMessage() for r in caplog.records if "readout failed" in r.getMessage()]
    assert len(first) == 1 and "read capture buffer" in first[0], first
    assert LINK_REASON.search(first[0].split("connection lost: ", 1)[1]), first


def test_killed_while_polling_the_capture_then_refused(server, monkeypatch):
    """Killed between two state polls: pymodbus's own request meets the dead socket (formerly a
    raw ConnectionResetError); a new connection is refused with the OS reason, not a settings
    repr."""
    daq = ModbusDaq(ModbusTcpSettings("127.0.0.1", server.port), timeout_s=1.0,
                    instrument_name="daq-b").connect()
    status = daq.status
    polls = []

    def status_then_kill():
        polls.append(1)
        if len(polls) == 2:
            server.kill()
        return status()

    monkeypatch.setattr(daq, "status", status_then_kill)
    try:
        with pytest.raises(TransportLost) as caught:
            daq.capture(0.2, 20000.0)
    finally:
        daq.close()
    assert len(polls) == 2
    assert_lost(caught.value, "daq-b", "read state")

    with pytest.raises(TransportLost) as refused:
        ModbusDaq(ModbusTcpSettings("127.0.0.1", server.port), instrument_name="daq-b").connect()
    assert str(refused.value) == (f"daq-b: connect: cannot connect to 127.0.0.1:{server.port}: "
                                  f"{refused.value.reason}")
    assert re.fullmatch(r"\[Errno \d+\] Connection refused", refused.value.reason)
    assert isinstance(refused.value.__cause__, ConnectionRefusedError)
