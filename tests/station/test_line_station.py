"""The station as a line station (issue 32 item 3), on the simulated bench through the station's
own run manager (the same child ``hil run``):

* ``--requirements`` / per-selection requirements and ``--results-db`` reach the run: the unit is
  judged against them, indexed in that database under the scanned serial;
* the final banner states conformity to the requirements, and says plainly when none were given
  (never a green PASS then);
* a unit stopped with Stop says what was done and what to do next (not "interrupted (Ctrl-C)");
* progress counts pytest items as the totals do (no "self_check 4 / 3").
"""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from hil.record import load_record
from hil.station import view
from hil.station.runs import RunManager

pytestmark = [pytest.mark.slow, pytest.mark.timeout(300)]

#: the customer's limit on the baseline's pk-pk: the correct drive's ~0.7 % passes 3 %
BASELINE_ONLY = '''
title = "line EOL spec (baseline only)"
[[requirement]]
id = "EOL-1"
name = "total torque ripple"
quantity = "pk_pk_pct"
limit = { max = 3.0 }
source = "baseline"
'''


def _wait(manager: RunManager, predicate, timeout_s: float = 240):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        manager.refresh()
        if predicate(manager.run):
            return manager.run
        time.sleep(0.05)
    raise AssertionError(f"timed out; child output: {manager.log_tail(20)}")


def test_a_line_station_judges_indexes_and_says_what_it_did(tmp_path, monkeypatch):
    from hil.results.db import engine_for
    from hil.results.queries import history

    monkeypatch.delenv("RIPPLE_HIL_RESULTS_DB", raising=False)
    spec = tmp_path / "eol.toml"
    spec.write_text(BASELINE_ONLY)
    url = f"sqlite:///{tmp_path / 'line.sqlite'}"
    manager = RunManager(None, tmp_path / "records", results_db=url,
                         selection_requirements={frozenset(["baseline"]): str(spec)})
    try:
        # 1. the selection "baseline" with its own requirements, indexed in --results-db
        manager.start("EPS-A-0007", ["baseline"], ["baseline", "self_check"])
        run = _wait(manager, lambda r: not r.alive)
        assert run.exit_status == 0, manager.log_tail(20)
        record = load_record(run.record_dir)
        final = view.final_statement(record, run.record_dir)
        assert final["banner"]["tone"] == "PASS"
        assert final["banner"]["text"].startswith("Conforms to the requirements")
        assert [r["record_id"] for r in history(engine_for(url), dut="EPS-A-0007")] == [
            record["record_id"]]
        assert view.unit_of(record) == "EPS-A-0007"
        # progress counts pytest items: self_check records 5 entries for its 4 tests
        rows = {r["source"]: r for r in view.progress(record, {"self_check": 4, "baseline": 1})}
        assert (rows["self_check"]["done"], rows["self_check"]["total"]) == (4, 4)

        # 2. no requirements for these plans; stopped with Stop after the first point
        manager.start("EPS-A-0008", ["self_check", "baseline"], ["baseline", "self_check"])
        _wait(manager, lambda r: r.follower is not None and r.follower.data
              and len(r.follower.data.get("tests", [])) >= 1)
        manager.stop()
        run = _wait(manager, lambda r: not r.alive)
        record = load_record(run.record_dir)
        assert record["status"] == "interrupted"
        final = view.final_statement(record, run.record_dir)
        assert final["banner"]["tone"] == "none" and "PASS" not in final["banner"]["text"]
        assert "NOT stated" in final["banner"]["text"]
        lines = dict(final["lines"])
        assert "Ctrl-C" not in lines["4. Run status and integrity"]
        assert "Stop" in lines["4. Run status and integrity"]
        stopped = [a for a in view.alerts(record) if a["kind"] == "stopped"]
        assert len(stopped) == 1 and "scan it and press Start again" in stopped[0]["text"]
        assert "do not release it" in stopped[0]["text"]
    finally:
        manager.close()


def test_no_requirements_given_is_never_a_green_pass():
    """The banner of a run that passed everything but judged no requirement."""
    class Statement:
        requirements = "no requirements given"
        overall = "PASS"

    banner = view.banner(Statement())
    assert banner["tone"] == "none" and "NOT stated" in banner["text"]


def test_progress_counts_one_point_per_pytest_item():
    record = {"tests": [
        {"test_id": "t.py::a", "nodeid": "t.py::a", "source": "self_check", "outcome": "passed"},
        {"test_id": "t.py::b-reference", "nodeid": "t.py::b", "source": "self_check",
         "outcome": "passed"},
        {"test_id": "t.py::b", "nodeid": "t.py::b", "source": "self_check", "outcome": "failed"},
    ]}
    row = view.progress(record, {"self_check": 3})[0]
    assert (row["done"], row["total"], row["passed"], row["bad"]) == (2, 3, 1, 1)
