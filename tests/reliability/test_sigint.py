"""SIGINT to the pytest process mid-sweep, checked on the instruments from a third process.

``hil sim-bench`` serves the simulated instruments in one process; ``hil run --bench`` (pytest
and the plugin) measures in a second; this test interrupts the second once a point is recorded,
then reads the instruments itself over their real transports — raw CANopen SDO uploads (no NMT
command, no state change) and Modbus reads — to see what the interrupted run left behind: the
drive switch-on-disabled, every injection at its EDS default, the DAQ idle, the dyno reference 0.
(tests/integration/test_run.py checks the interrupted run's record; here the bench is the point.)
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import canopen
import pytest

from ripple_hil_drivers import canopen_402 as sm
from ripple_hil_drivers.canopen_eds import injection_objects, load_dictionary
from ripple_hil_drivers.canopen_transport import CanBusSettings, open_bus
from ripple_hil_drivers.modbus_daq import ModbusDaq, ModbusTcpSettings
from hil.config import load_bench
from hil.record import load_record, verify_captures

HIL = [sys.executable, "-m", "hil"]

pytestmark = [pytest.mark.integration, pytest.mark.slow, pytest.mark.timeout(300)]


def wait_for(condition, timeout_s: float, what: str, process=None):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        value = condition()
        if value:
            return value
        if process is not None and process.poll() is not None:
            pytest.fail(f"{what}: the process exited early ({process.returncode})")
        time.sleep(0.05)
    pytest.fail(f"timed out waiting for {what}")


def recorded_points(records) -> int:
    """Tests finished so far (record.json holds the header; load_record replays the journal;
    the selected tests are listed as "not run" until they run). A point's entry appears when
    it is measured, mid-call, without a ``phase``: only the outcome at the test's end sets one
    (a Ctrl-C in the rest of that test makes it "not run", and the run had finished none)."""
    for path in records.glob("*/record.json"):
        try:
            return sum(t["outcome"] in ("passed", "failed") and bool(t.get("phase"))
                       for t in load_record(path.parent)["tests"])
        except Exception:  # noqa: BLE001 - a record being created
            return 0
    return 0


def stop_processes(*processes) -> None:
    """Terminate whatever is still running (None entries skipped); kill what does not stop."""
    for process in processes:
        if process is not None and process.poll() is None:
            process.terminate()
            try:
                process.wait(timeout=30)
            except subprocess.TimeoutExpired:
                process.kill()


def read_drive_raw(config) -> tuple[str, dict[str, int]]:
    """CiA 402 state and every injection knob's raw count, by SDO upload only."""
    settings = CanBusSettings(interface=config.drive.interface, channel=config.drive.channel,
                              bitrate=config.drive.bitrate)
    network = canopen.Network(open_bus(settings))
    network.connect()
    try:
        node = network.add_node(config.drive.node_id, load_dictionary(None, config.drive.node_id))
        node.sdo.RESPONSE_TIMEOUT = 2.0
        state = sm.state_from_statusword(node.sdo[0x6041].raw)
        knobs = {name: node.sdo[obj.index].raw for name, obj in injection_objects().items()}
    finally:
        network.disconnect()
    return state, knobs


def test_sigint_mid_sweep_leaves_the_bench_safe(tmp_path):
    bench_file = tmp_path / "sim.toml"
    records = tmp_path / "records"
    server = subprocess.Popen(HIL + ["sim-bench", "--duration-s", "280", "-o", str(bench_file)],
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    run = None
    try:
        wait_for(bench_file.exists, 60, "the sim-bench bench file", server)
        config = load_bench(bench_file)
        env = dict(os.environ, PYTHONUNBUFFERED="1")
        run = subprocess.Popen(HIL + ["run", "--bench", str(bench_file), "--source", "dc_offset",
                                      "--source", "dead_time", "--no-report",
                                      "--record-dir", str(records)],
                               stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                               env=env, cwd=tmp_path)
        wait_for(lambda: recorded_points(records) >= 1, 180, "the first recorded point", run)
        run.send_signal(signal.SIGINT)
        output, _ = run.communicate(timeout=120)
        assert run.returncode != 0, output[-2000:]

        folder = next(records.glob("*/record.json")).parent
        record = load_record(folder)
        assert record["status"] == "interrupted", output[-2000:]
        finished = [t for t in record["tests"] if t["outcome"] in ("passed", "failed")]
        assert 1 <= len(finished) < 8, output[-3000:]
        assert all(t["capture"]["sha256"] for t in finished)
        assert verify_captures(folder, record) == []

        state, knobs = read_drive_raw(config)
        assert state == sm.SWITCH_ON_DISABLED
        defaults = {name: obj.default_count for name, obj in injection_objects().items()}
        assert knobs == defaults
        with ModbusDaq(ModbusTcpSettings(config.daq.host, config.daq.port)) as daq:
            assert daq.status()["state"] in ("idle", "disarmed")
            assert daq.dyno_speed_rpm() == 0.0
    finally:
        stop_processes(run, server)


LONG_POINT_PLAN = '''
from hil.measurement import PointPlan


def test_long_point(measure):
    """One point whose capture runs for seconds of wall time (a long settle, in simulated time)."""
    measure(PointPlan(source="dc_offset", injection={"ia_offset_a": 0.4, "ib_offset_a": 0.0},
                      speed_rpm=500.0, current_a=20.0, revolutions=8, settle_s=55.0))
'''


def test_killed_test_process_leaves_the_drive_disabled(tmp_path):
    bench_file = tmp_path / "sim.toml"
    plan = tmp_path / "test_long_point.py"
    plan.write_text(LONG_POINT_PLAN)
    server = subprocess.Popen(HIL + ["sim-bench", "--duration-s", "120", "-o", str(bench_file)],
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    run = None
    try:
        wait_for(bench_file.exists, 60, "the sim-bench bench file", server)
        config = load_bench(bench_file)
        run = subprocess.Popen([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                                str(plan), "--hil-bench", str(bench_file),
                                "--hil-record", str(tmp_path / "records")],
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                               cwd=tmp_path)
        with ModbusDaq(ModbusTcpSettings(config.daq.host, config.daq.port)) as daq:
            wait_for(lambda: daq.status()["state"] == "capturing", 120, "the capture", run)
        run.send_signal(signal.SIGKILL)
        run.wait(timeout=30)
        time.sleep(3 * config.drive.heartbeat_timeout_s)   # any master-loss timeout has passed
        state, knobs = read_drive_raw(config)
        assert state == sm.SWITCH_ON_DISABLED, f"drive left {state} with injections {knobs}"
        defaults = {name: obj.default_count for name, obj in injection_objects().items()}
        assert knobs == defaults, "the lost master's injections were not restored"
    finally:
        stop_processes(run, server)
