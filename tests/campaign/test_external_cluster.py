"""``hil yield --scheduler tcp://HOST:PORT`` against a separately started Dask cluster (the
``dask scheduler`` / ``dask worker`` command lines of the installed ``distributed``, on
127.0.0.1, free ports), with the same result as the inline run for the same seed."""

import dataclasses
import json
import subprocess
import sys
import time
from pathlib import Path

import pytest

from hil.tolerance.run import YieldOptions, run_yield
from hil.tolerance.spec import load_tolerances

EXAMPLE = Path(__file__).resolve().parents[2] / "hil" / "examples" / "tolerances.toml"
#: the cluster stops by itself if this test is killed: the scheduler after 60 s without work,
#: the workers 20 s after losing it
IDLE_TIMEOUT_S = 60
DEATH_TIMEOUT_S = 20


def _stop(process: subprocess.Popen) -> None:
    if process.poll() is None:
        process.terminate()
        try:
            process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait(timeout=10)


@pytest.fixture(scope="module")
def external_cluster(tmp_path_factory, twin_compiled):
    """A scheduler (port 0: the OS picks a free one, written to its scheduler file) and one
    ``dask worker`` process with two single-thread worker processes; both stopped at the end."""
    tmp_path = tmp_path_factory.mktemp("cluster")
    dask = [sys.executable, "-m", "dask"]
    address_file = tmp_path / "scheduler.json"
    logs = {name: open(tmp_path / f"{name}.log", "w") for name in ("scheduler", "worker")}
    processes = []
    try:
        processes.append(subprocess.Popen(
            dask + ["scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                    "--scheduler-file", str(address_file),
                    "--idle-timeout", f"{IDLE_TIMEOUT_S}s"],
            cwd=tmp_path, stdout=logs["scheduler"], stderr=subprocess.STDOUT))
        deadline = time.monotonic() + 30
        while not address_file.exists() or not address_file.read_text().strip():
            assert processes[0].poll() is None, (tmp_path / "scheduler.log").read_text()
            assert time.monotonic() < deadline, "the dask scheduler did not start in 30 s"
            time.sleep(0.1)
        address = json.loads(address_file.read_text())["address"]
        assert address.startswith("tcp://127.0.0.1:")
        processes.append(subprocess.Popen(
            dask + ["worker", address, "--host", "127.0.0.1", "--nworkers", "2",
                    "--nthreads", "1", "--no-dashboard", "--death-timeout",
                    f"{DEATH_TIMEOUT_S}s", "--local-directory", str(tmp_path / "workers")],
            cwd=tmp_path, stdout=logs["worker"], stderr=subprocess.STDOUT))
        from distributed import Client
        with Client(address, timeout="30s") as client:
            client.wait_for_workers(2, timeout=60)
        yield address
    finally:
        for process in reversed(processes):
            _stop(process)
        for log in logs.values():
            log.close()


def _results(summary: dict) -> dict:
    """Everything of a summary but where and how fast it ran."""
    return {k: v for k, v in summary.items() if k not in ("campaign", "figures")}


@pytest.mark.parametrize("engine, drives, chunk", [("twin", 8, 2), ("closed-form", 3000, 1000)])
def test_yield_on_an_external_cluster_equals_inline(tmp_path, external_cluster, engine, drives,
                                                    chunk):
    done = subprocess.run(
        [sys.executable, "-m", "hil", "yield", str(EXAMPLE), "--engine", engine, "--drives",
         str(drives), "--chunk-size", str(chunk), "--sobol-n", "8", "--scheduler",
         external_cluster, "--out", str(tmp_path / "cluster"), "--json"],
        capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    cluster = json.loads(done.stdout)
    assert cluster["campaign"]["scheduler"] == external_cluster
    assert cluster["campaign"]["workers"] == 2 and cluster["campaign"]["chunks_computed"] > 1
    spec = dataclasses.replace(load_tolerances(EXAMPLE), drives=drives)
    inline = run_yield(spec, tmp_path / "inline",
                       YieldOptions(engine=engine, scheduler="inline", chunk_size=chunk,
                                    sobol_n=8, progress=False, plots=False))
    assert cluster["drives"] == drives
    # the same drives, the same ripple, the same statistics: bit for bit (JSON floats round-trip)
    assert _results(cluster) == json.loads(json.dumps(_results(inline)))


GRID = """
bench = "sim-bench"
plans = [["baseline"]]
[axes.host]        # a loaded host: the simulated instruments' answers may take > 0.5 s
patient = {"drive.sdo_timeout_s" = 3.0, "drive.heartbeat_timeout_s" = 5.0, "daq.timeout_s" = 5.0}
[axes.point]
forward = {"operating_point.speed_rpm" = 500.0}
reverse = {"operating_point.speed_rpm" = -500.0}
"""


def test_grid_on_an_external_cluster(tmp_path, external_cluster):
    """``hil campaign GRID.toml --scheduler ADDRESS``: a tiny grid (2 runs, one plan each) on
    the separately started scheduler and its 2 workers; both runs' records come back sealed
    and are indexed, the summary lists them."""
    grid = tmp_path / "grid.toml"
    grid.write_text(GRID)
    done = subprocess.run(
        [sys.executable, "-m", "hil", "campaign", str(grid), "--scheduler", external_cluster,
         "--out", str(tmp_path / "out"), "--results-db", f"sqlite:///{tmp_path / 'r.sqlite'}",
         "--json"], capture_output=True, text=True, timeout=400)
    assert done.returncode == 0, done.stderr + done.stdout
    summary = json.loads(done.stdout)
    assert summary["workers"] == 2 and summary["computed"] == 2 and summary["indexed"] == 2
    assert [row["state"] for row in summary["runs"]] == ["done", "done"]
    assert all(row["outcomes"].get("passed", 0) > 0 for row in summary["runs"])
    assert all(Path(row["record"], "record.sha256").exists() for row in summary["runs"])
