"""Opening the bench (issue 11 item 5): the DAQ and the transducer are connected and identified
before the first CAN write to the drive; a bench that cannot open fails with one error that names
the instrument, what was tried and why (the OS reason, not a settings repr). And the plugin stays
inert in a pytest run that uses none of its options or fixtures (issue 12 item 6)."""

from __future__ import annotations

import signal
import socket
import subprocess
import sys

import pytest

from ripple_hil_drivers.cia402 import Cia402Drive
from hil.bench import Bench, BenchOpenError
from hil.config import default_sim_bench
from hil.simbench import SimulatedBench

pytestmark = pytest.mark.integration


@pytest.fixture(scope="module")
def served():
    """The simulated instruments, started once; tests open benches against their addresses."""
    simulated = SimulatedBench(default_sim_bench(), seed=1)
    config = simulated.start()
    yield config
    simulated.stop()


@pytest.fixture
def drive_connects(monkeypatch):
    """Counts the drive's connect() calls (its first CAN write is inside connect())."""
    calls = []
    real = Cia402Drive.connect

    def counted(self):
        calls.append(self)
        return real(self)

    monkeypatch.setattr(Cia402Drive, "connect", counted)
    return calls


def closed_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def test_the_bench_opens_daq_and_transducer_before_the_drive(served, drive_connects):
    bench = Bench.open(served)
    try:
        assert len(drive_connects) == 1
        roles = [row["role"] for row in bench.identities()]
        assert roles == ["drive", "daq", "torque"]
        assert all("error" not in row for row in bench.identities())
    finally:
        bench.close()


def test_a_wrong_daq_port_never_touches_the_drive(served, drive_connects):
    port = closed_port()
    with pytest.raises(BenchOpenError) as caught:
        Bench.open(served.with_overrides({"daq": {"port": port}}))
    assert drive_connects == []
    error = caught.value
    assert error.instrument == "daq" and f"127.0.0.1:{port}" in error.tried
    assert "Connection refused" in error.reason and "Settings" not in str(error)
    assert "\n" not in str(error)


def test_a_missing_serial_port_never_touches_the_drive(served, drive_connects):
    with pytest.raises(BenchOpenError) as caught:
        Bench.open(served.with_overrides({"torque": {"serial_port": "/dev/ripple-hil-absent"}}))
    assert drive_connects == []
    assert caught.value.instrument == "torque"
    assert "/dev/ripple-hil-absent" in str(caught.value) and "\n" not in str(caught.value)


def test_a_can_interface_without_its_library_is_one_line(served):
    with pytest.raises(BenchOpenError) as caught:
        Bench.open(served.with_overrides({"drive": {"interface": "pcan",
                                                    "channel": "PCAN_USBBUS1"}}))
    assert caught.value.instrument == "drive" and "pcan" in caught.value.tried
    assert "\n" not in str(caught.value)


PLAIN_TESTS = '''
import signal

def test_plain():
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler

def test_plain_too():
    import sys
    loaded = [m for m in sys.modules if m.startswith(("hil.sim", "hil.analysis", "numba"))]
    assert loaded == []           # the plugin costs an unrelated run no simulation import
'''


def test_the_plugin_is_inert_in_an_unrelated_pytest_run(tmp_path):
    (tmp_path / "test_plain.py").write_text(PLAIN_TESTS)
    done = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                           "test_plain.py"], capture_output=True, text=True, timeout=120,
                          cwd=tmp_path)
    assert done.returncode == 0, done.stdout
    assert "ripple-hil" not in done.stdout
    assert not (tmp_path / "records").exists()
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_loading_the_plugin_imports_no_simulation_or_analysis():
    """The plugin is in every pytest run of the environment: it must cost little to load."""
    code = ("import sys, fixtures.plugin; "
            "print(sorted(m for m in sys.modules if m.startswith(('hil.sim', 'hil.analysis', "
            "'numba', 'matplotlib', 'fpdf'))))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=60)
    assert done.returncode == 0 and done.stdout.strip() == "[]", done.stdout + done.stderr
