"""The station's run manager on the simulated bench: the same ``hil run`` as a child process.

* one run per bench: a second Start is refused with the reason, by the same station and by a
  second station on the same bench (file lock);
* operator prompts (``fixtures/operator.py``): the question reaches the station through the
  record's journal, the operator's answer reaches the plan, both are recorded; headless, the
  plan's default is used and recorded, and a question without a default fails its test;
* a correct drive at another operating point (reverse rotation, 15 A) raises no alert; a
  drive whose transducer reads 5 % high fails the self-check and the station says so.
"""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import pytest

from hil.config import example_bench_path
from hil.record import load_record
from hil.station import view
from hil.station.runs import Refused, RunManager

pytestmark = pytest.mark.slow

# A plan needs its ripple_source marker: fixtures/session.py's Selection.to_dict sorts the
# sources and fails (TypeError) on a collected test without one.
PROMPT_PLAN = '''
import pytest

pytestmark = pytest.mark.ripple_source("operator_demo")


def test_operator_couples_and_enters_voltage(operator_prompts):
    operator_prompts.confirm("couple", "Couple the transducer, then Continue")
    volts = operator_prompts.ask("supply_v", "Enter the supply voltage in V", default="48")
    assert volts == "{expected}"
'''
HEADLESS_NO_DEFAULT = '''

def test_needs_an_operator(operator_prompts):
    operator_prompts.ask("serial_of_dyno", "Enter the dyno serial number")
'''
PLANS = ["baseline", "self_check"]


def _wait(manager: RunManager, predicate, timeout_s: float = 240):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        manager.refresh()
        if predicate(manager.run):
            return manager.run
        time.sleep(0.05)
    raise AssertionError(f"timed out; child output: {manager.log_tail(20)}")


def test_station_run_prompts_answers_and_one_run_per_bench(tmp_path):
    bench = tmp_path / "reverse.toml"
    bench.write_text(Path(example_bench_path("sim-bench")).read_text()
                     .replace("speed_rpm = 500.0", "speed_rpm = -400.0")
                     .replace("current_a = 20.0", "current_a = 15.0"))
    plan = tmp_path / "test_prompt_plan.py"
    plan.write_text(PROMPT_PLAN.format(expected="47.5"))
    manager = RunManager(str(bench), tmp_path / "records", extra_args=[str(plan)])
    other_station = RunManager(str(bench), tmp_path / "records")
    try:
        with pytest.raises(Refused, match="serial number"):
            manager.start("", ["self_check"], PLANS)
        manager.start("SN-REV-7", ["self_check"], PLANS)
        with pytest.raises(Refused, match="already going on this bench"):
            manager.start("SN-8", ["self_check"], PLANS)
        with pytest.raises(Refused, match="another station"):
            other_station.start("SN-8", ["self_check"], PLANS)
        manager._release_bench_lock()       # as if this station died: the run holds the lock
        with pytest.raises(Refused, match="another station"):
            other_station.start("SN-8", ["self_check"], PLANS)
        run = _wait(manager, lambda r: r.follower and view.prompts(r.follower.data)
                    or not r.alive)
        assert [p["key"] for p in view.prompts(run.follower.data)] == ["couple"]
        with pytest.raises(Refused, match="no such question is waiting"):
            manager.answer("supply_v", "99")          # not asked yet: never pre-answered
        manager.answer("couple", "continue")
        with pytest.raises(Refused, match="already answered"):
            manager.answer("couple", "continue")
        run = _wait(manager, lambda r: [p["key"] for p in view.prompts(r.follower.data)]
                    == ["supply_v"] or not r.alive)
        manager.answer("supply_v", "47.5")
        run = _wait(manager, lambda r: not r.alive and r.follower and r.follower.finished)
    finally:
        manager.close()
        other_station.close()
    record = load_record(run.record_dir)
    assert run.exit_status == 0, manager.log_tail(20)
    assert record["status"] == "complete" and record["unit"]["serial_number"] == "SN-REV-7"
    assert record["bench"]["loaded"]["operating_point"]["speed_rpm"] == -400.0
    asked = {p["key"]: p for p in record["operator_prompts"]["prompts"]}
    assert asked["couple"]["by"] == asked["supply_v"]["by"] == "station operator"
    assert asked["supply_v"]["answer"] == "47.5" and asked["supply_v"]["answered_utc"]
    assert view.alerts(record) == []
    assert view.final_statement(record, run.record_dir)["lines"][2] == \
        ["3. Bench self-check", "PASS"]


def test_headless_defaults_and_a_wrong_transducer_alert(tmp_path):
    plan = tmp_path / "test_prompt_plan.py"
    plan.write_text(PROMPT_PLAN.format(expected="48") + HEADLESS_NO_DEFAULT)
    result = subprocess.run(
        [sys.executable, "-m", "hil", "run", "--source", "self_check", "--no-report",
         "--record-dir", str(tmp_path / "records"), "--sim-defect", "transducer_scale=1.05",
         "--", str(plan)], capture_output=True, text=True, timeout=300)
    folder = next((tmp_path / "records").iterdir())
    record = load_record(folder)
    outcomes = {t["test_id"].rsplit("::", 1)[-1]: t for t in record["tests"]}
    assert outcomes["test_operator_couples_and_enters_voltage"]["outcome"] == "passed"
    needs = outcomes["test_needs_an_operator"]
    assert needs["outcome"] == "failed" and "needs an operator" in needs["message"]
    asked = {p["key"]: p for p in record["operator_prompts"]["prompts"]}
    assert asked["supply_v"]["answer"] == "48"
    assert asked["supply_v"]["by"] == asked["couple"]["by"] == "default (no operator)"
    assert asked["serial_of_dyno"]["answer"] is None
    kinds = [alert["kind"] for alert in view.alerts(record)]
    assert kinds == ["self-check"], (kinds, result.stdout[-2000:])
    assert "FAILED" in view.alerts(record)[0]["text"]


VANISH = '''
import pytest
from hil.measurement import PointPlan

pytestmark = pytest.mark.ripple_source("dc_offset")


@pytest.mark.parametrize("offset_a", [0.1, 0.2, 0.3])
def test_point(measure, bench, offset_a):
    if offset_a == 0.2:
        bench.simulated.stop()          # every in-process simulated instrument vanishes
    measure(PointPlan(source="dc_offset", injection={"ia_offset_a": offset_a, "ib_offset_a": 0.0},
                      speed_rpm=500.0, current_a=20.0, revolutions=3))
'''


def test_a_lost_bench_is_shown_with_the_instrument(tmp_path):
    plan = tmp_path / "test_vanish.py"
    plan.write_text(VANISH)
    manager = RunManager(None, tmp_path / "records", extra_args=[str(plan)])
    try:
        manager.start("SN-LOST-3", ["self_check"], PLANS)
        run = _wait(manager, lambda r: not r.alive and r.follower and r.follower.finished)
    finally:
        manager.close()
    assert run.exit_status == 7, manager.log_tail(20)
    record = run.follower.data
    assert record["status"] == "aborted"
    alerts = view.alerts(record)
    assert alerts[0]["kind"] == "bench-lost" and "(drive)" in alerts[0]["text"]
    # the alert stood as soon as the failed point's line was in the journal, before the end
    failed = next(e for e in run.follower.events if e.get("event") == "update"
                  and "bench lost" in str(e["fields"].get("message"))
                  or e.get("event") == "test" and "bench lost" in str(e["entry"].get("message")))
    assert failed is not None
