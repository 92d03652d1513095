"""``hil campaign``'s engine on a 2-worker LocalCluster: a tiny grid (2 runs, one plan each) in
which one worker is killed (SIGKILL) while it runs a plan; every run ends with exactly one
sealed record, indexed once in the results database, and a rerun computes nothing."""

import os
import signal
import threading
import time

import psutil
import pytest

from hil.campaign import dask_client
from hil.campaign.grid import RUN_FILE, run_grid, summary_table
from hil.campaign.grid_spec import load_grid
from hil.record import verify_record

GRID = """
bench = "sim-bench"
plans = [["baseline"]]
[axes.host]        # a loaded host: the simulated instruments' answers may take > 0.5 s
patient = {"drive.sdo_timeout_s" = 3.0, "drive.heartbeat_timeout_s" = 5.0, "daq.timeout_s" = 5.0}
[axes.point]
forward = {"operating_point.speed_rpm" = 500.0}
slower = {"operating_point.speed_rpm" = 400.0}
"""


def _kill_a_worker_mid_run(client, killed: list, stop: threading.Event) -> None:
    """SIGKILL the first worker seen running a plan (its ``hil run`` child alive for 1 s)."""
    pids = client.run(os.getpid)
    while not stop.is_set():
        for pid in pids.values():
            try:
                children = psutil.Process(pid).children()
            except psutil.NoSuchProcess:
                continue
            if any(time.time() - c.create_time() > 1.0 for c in children):
                os.kill(pid, signal.SIGKILL)
                killed.append(pid)
                return
        time.sleep(0.2)


@pytest.mark.timeout(600)
def test_grid_survives_a_killed_worker_and_resumes(tmp_path):
    path = tmp_path / "grid.toml"
    path.write_text(GRID)
    runs = load_grid(path)
    assert len(runs) == 2
    url = f"sqlite:///{tmp_path / 'results.sqlite'}"
    folder = tmp_path / "grid"
    with dask_client(n_workers=2) as client:
        killed, stop = [], threading.Event()
        killer = threading.Thread(target=_kill_a_worker_mid_run, args=(client, killed, stop))
        killer.start()
        try:
            result = run_grid(runs, folder, client=client, results_db=url, progress=False)
        finally:
            stop.set()
            killer.join()
    assert killed, "no worker was seen running a plan"
    assert sorted(result.computed) == sorted(r.key for r in runs) and not result.failed
    # one record per run, sealed and intact; no stray temp folder
    assert sorted(p.name for p in (folder / "runs").iterdir()) == sorted(r.key for r in runs)
    for run in runs:
        record = folder / "runs" / run.key / "record"
        assert (folder / "runs" / run.key / RUN_FILE).exists()
        assert verify_record(record) == []
    assert all(row["state"] == "done" and row["overall"] for row in result.rows)
    from sqlalchemy import create_engine, func, select

    from hil.results.schema import runs as runs_table
    with create_engine(url).connect() as connection:
        assert connection.execute(select(func.count()).select_from(runs_table)).scalar() == 2
    # the rerun finds both done: nothing computed, no cluster needed
    again = run_grid(runs, folder, results_db=url, progress=False)
    assert again.computed == [] and sorted(again.skipped) == sorted(r.key for r in runs)
    assert "2/2 done" in summary_table(again.rows)
