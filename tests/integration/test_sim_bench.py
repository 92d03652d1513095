"""`hil sim-bench` in one process, the test plans in another, joined only by the bench file."""

import subprocess
import sys
import time

from hil.outcome_kinds import MEASURED
from hil.config import load_bench
from hil.record import load_record

HIL = [sys.executable, "-m", "hil"]


def test_second_process_runs_plans_against_sim_bench(tmp_path):
    bench_file = tmp_path / "sim.toml"
    server = subprocess.Popen(HIL + ["sim-bench", "--duration-s", "240", "-o", str(bench_file)],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 60
        while not bench_file.exists():
            assert server.poll() is None, server.stderr.read()
            assert time.monotonic() < deadline, "sim-bench never wrote its bench file"
            time.sleep(0.1)
        bench = load_bench(bench_file)
        assert bench.drive.interface == "remote"
        assert bench.drive.channel.startswith("ws://127.0.0.1:")
        assert bench.daq.host == "127.0.0.1" and bench.daq.port
        assert bench.torque.serial_port.startswith("/dev/")
        done = subprocess.run(HIL + ["run", "--bench", str(bench_file), "--source", "gain_mismatch",
                                     "--no-report", "--record-dir", str(tmp_path / "rec")],
                              capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]
        record = load_record(next((tmp_path / "rec").iterdir()))
        # --source always runs the bench self-check first
        measured = [t for t in record["tests"] if t["measured"] and t["source"] == "gain_mismatch"]
        assert record["status"] == "complete" and len(measured) == 3
        assert all(t["outcome"] in ("passed", MEASURED) for t in record["tests"]), [
            (t["test_id"], t["outcome"], t.get("message")) for t in record["tests"]]
        assert {t["measured"]["dominant_order"] for t in measured} == {2}
        assert record["tests"][0]["test_id"] == "testplans/test_self_check.py::test_bench_self_check"
        assert all(t["test_id"].startswith("testplans/test_gain_mismatch.py::")   # as pytest
                   for t in record["tests"] if t["source"] != "self_check")
    finally:
        server.terminate()
        server.wait(timeout=30)
    assert server.returncode == 0
