"""``hil run`` indexes its sealed record in the results database (design.md §10: a sink after
the seal): by default an SQLite file beside the records, with the DUT serial given; a database
that cannot be reached leaves the run's exit status, record and seal untouched (one warning line,
``hil db sync`` later)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time

import pytest

from hil.record import verify_record

pytestmark = pytest.mark.timeout(240)


def hil(*args: str, cwd) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k != "RIPPLE_HIL_RESULTS_DB"}
    env["PYTHONPATH"] = os.pathsep.join(sys.path)
    return subprocess.run([sys.executable, "-m", "hil", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=200)


def test_a_run_is_indexed_with_its_dut_serial(tmp_path):
    done = hil("run", "--source", "baseline", "--no-report", "--dut-serial", "UNIT-42",
               "--record-dir", "records", cwd=tmp_path)
    assert done.returncode == 0, done.stderr[-2000:]
    assert (tmp_path / "records" / "results.sqlite").exists()
    listed = hil("history", "--records", "records", "--json", cwd=tmp_path)
    assert listed.returncode == 0, listed.stderr
    runs = json.loads(listed.stdout)["runs"]
    assert [run["dut_serial"] for run in runs] == ["UNIT-42"]
    record_dir = next(p for p in (tmp_path / "records").iterdir() if p.is_dir())
    assert runs[0]["record_id"] == record_dir.name


def test_a_database_that_is_down_changes_nothing_of_the_run(tmp_path):
    start = time.monotonic()
    done = hil("run", "--source", "baseline", "--no-report", "--record-dir", "records",
               "--results-db", "postgresql://nobody@127.0.0.1:1/none", cwd=tmp_path)
    elapsed = time.monotonic() - start
    assert done.returncode == 0, done.stderr[-2000:]
    assert "hil db sync" in done.stderr                     # says how to index it later
    record_dir = next(p for p in (tmp_path / "records").iterdir() if p.is_dir())
    assert verify_record(record_dir) == []                  # sealed and intact
    assert elapsed < 60
