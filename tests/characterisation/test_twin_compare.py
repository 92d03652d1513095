"""Done-when of issue 29's twin, through the real CLI in subprocesses: a twin written by
``hil characterize --write-twin`` from a bench whose physics is not its nameplate (R × 1.3,
L × 0.8, Ke × 0.96, loop × 0.9) reproduces that bench's ``hil run`` within U on every judged
point (``hil compare``), and the same bench with a hidden fault added after the twin was
written (a 0.3 A offset on phase a's current sensor) is named by the compare, point by point
and plan by plan. Reduced plan selection (baseline, dead time, and the self-check every run
has); the full plan set: studies/results/twin_compare.md."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import tomllib

import pytest

from hil.config import example_bench_path

pytestmark = pytest.mark.slow      # characterize + three reduced `hil run`s, one after another

SOURCES = ("--source", "baseline", "--source", "dead_time")
#: The bench's hidden physics, as multiples of its file's [motor] and [drive].
DEVIATION = {"phase_resistance_ohm": 1.3, "phase_inductance_h": 0.8, "ke_v_s_per_rad": 0.96,
             "current_loop_bandwidth_hz": 0.9}
DEAD_TIME_POINTS = [f"testplans/test_dead_time.py::test_dead_time[dead_time_s={t}]"
                    for t in ("2e-06", "3e-06", "4e-06")]
BASELINE = "testplans/test_baseline.py::test_baseline"
SELF_CHECK = "testplans/test_self_check.py::"


def _hil(*args: str, ok=(0,)) -> str:
    """The CLI as a user runs it: each run indexed into its records folder's results.sqlite
    (the tests' ``RIPPLE_HIL_RESULTS_DB=off`` left out), where ``hil compare`` reads them."""
    env = {key: value for key, value in os.environ.items() if key != "RIPPLE_HIL_RESULTS_DB"}
    env["PYTHONPATH"] = os.pathsep.join(sys.path)
    proc = subprocess.run([sys.executable, "-m", "hil", *args], capture_output=True, text=True,
                          env=env, timeout=600)
    assert proc.returncode in ok, (args, proc.returncode, proc.stdout[-3000:],
                                   proc.stderr[-3000:])
    return proc.stdout


def _run(bench, records, seed: int, ok=(0,)) -> str:
    """``hil run`` of the reduced selection; the record ID it printed."""
    out = _hil("run", "--bench", str(bench), *SOURCES, "--record-dir", str(records),
               "--no-report", "--seed", str(seed), ok=ok)
    return re.search(r"^record: \S+/(\S+) \(complete\)$", out, re.M).group(1)


def _deviated_bench(path):
    stated = tomllib.loads(example_bench_path("sim-bench").read_text())
    actual = {key: factor * (stated["drive"] if key.startswith("current_loop") else
                             stated["motor"])[key] for key, factor in DEVIATION.items()}
    text = example_bench_path("sim-bench").read_text() + "\n[simulation.actual]\n" + "".join(
        f"{key} = {value!r}\n" for key, value in actual.items())
    path.write_text(text)
    return stated, actual


@pytest.fixture(scope="module")
def bench_and_twin(tmp_path_factory):
    """The deviated bench, its twin file, and a run of each (other noise seeds)."""
    root = tmp_path_factory.mktemp("twin")
    bench, twin, records = root / "bench.toml", root / "twin.toml", root / "records"
    stated, actual = _deviated_bench(bench)
    _hil("characterize", "--bench", str(bench), "--record-dir", str(root / "characterisation"),
         "--write-twin", str(twin))
    ids = {"bench": _run(bench, records, seed=0), "twin": _run(twin, records, seed=1)}
    return {"root": root, "bench": bench, "twin": twin, "records": records, "ids": ids,
            "stated": stated, "actual": actual}


def _compare(records, a: str, b: str) -> dict:
    return json.loads(_hil("compare", a, b, "--records", str(records), "--json"))


def _record(records, record_id):
    from hil.record import load_record

    return load_record(records / record_id)


def test_the_twin_states_the_nameplate_and_runs_the_measured_physics(bench_and_twin):
    twin = tomllib.loads(bench_and_twin["twin"].read_text())
    stated, actual = bench_and_twin["stated"], bench_and_twin["actual"]
    # the drive was configured from the nameplate: the twin states it (its firmware's gains)
    for key in ("phase_resistance_ohm", "phase_inductance_h", "ke_v_s_per_rad"):
        assert twin["motor"][key] == stated["motor"][key]
    assert twin["drive"]["current_loop_bandwidth_hz"] == stated["drive"][
        "current_loop_bandwidth_hz"]
    # ... and runs what was measured, within the characterisation's reach of the hidden truth
    physics = twin["simulation"]["actual"]
    assert set(physics) == set(DEVIATION) and "defects" not in twin["simulation"]
    for key in ("phase_resistance_ohm", "phase_inductance_h", "ke_v_s_per_rad"):
        assert physics[key] == pytest.approx(actual[key], rel=0.08)
    assert physics["current_loop_bandwidth_hz"] == pytest.approx(
        actual["current_loop_bandwidth_hz"], rel=0.1)


def test_the_twin_reproduces_the_bench_within_u_on_every_judged_point(bench_and_twin):
    records, ids = bench_and_twin["records"], bench_and_twin["ids"]
    result = _compare(records, ids["twin"], ids["bench"])          # d = bench − twin
    verdict = result["reproduction"]
    assert verdict["reproduced"], verdict
    assert verdict["beyond_u"] == [] and verdict["verdicts_differ"] == []
    assert set(verdict["within_u"]) == {BASELINE, *DEAD_TIME_POINTS,
                                        SELF_CHECK + "test_bench_self_check",
                                        SELF_CHECK + "test_transducer_dynamics",
                                        SELF_CHECK + "test_transducer_dynamics-reference"}
    assert verdict["statement"].startswith("reproduced within U on every judged point (7 of 7")
    points = {p["test_id"]: p for p in result["points"]}
    for test_id in DEAD_TIME_POINTS:
        # the dead time's order 6 is shaped by the current loop: with the firmware's gains set
        # from the measured motor (the first twin) the twin's was 16 % below the bench's; with
        # the nameplate's, within the loop bandwidth's measured U (1.6-2.5 % in the full study)
        order6 = next(o for o in points[test_id]["orders"] if o["order"] == 6)
        assert abs(order6["difference"]) < 0.05 * order6["b"], (test_id, order6)
    # the twin's own characterisation states the bench's nameplate and finds its physics
    bench_rows = _record(records, ids["bench"])["characterisation"]["stated_vs_measured"]
    twin_rows = {r["name"]: r for r in
                 _record(records, ids["twin"])["characterisation"]["stated_vs_measured"]}
    for row in bench_rows:
        other = twin_rows[row["name"]]
        assert other["stated"] == row["stated"] and other["disagrees"] and row["disagrees"]
        assert abs(other["measured"] - row["measured"]) <= (row["U_k2"] ** 2
                                                            + other["U_k2"] ** 2) ** 0.5, row


def test_a_hidden_fault_the_twin_lacks_is_named(bench_and_twin):
    root, records = bench_and_twin["root"], bench_and_twin["records"]
    faulty = root / "bench-with-fault.toml"
    faulty.write_text(bench_and_twin["bench"].read_text()
                      + "\n[simulation.defects]\nhidden_ia_offset_a = 0.3\n")
    fault_id = _run(faulty, records, seed=2, ok=(1,))                  # its baseline fails
    result = _compare(records, bench_and_twin["ids"]["twin"], fault_id)
    verdict = result["reproduction"]
    assert not verdict["reproduced"]
    # a 0.3 A offset (1.5 % of 20 A) adds ~3.4 % pk-pk of order 1 at every regulated point
    assert set(verdict["beyond_u"]) == {BASELINE, *DEAD_TIME_POINTS,
                                        SELF_CHECK + "test_bench_self_check",
                                        SELF_CHECK + "test_transducer_dynamics",
                                        SELF_CHECK + "test_transducer_dynamics-reference"}
    assert verdict["plans_beyond_u"] == ["baseline", "dead_time", "self_check"]
    assert {"test_id": BASELINE, "outcome_a": "passed", "outcome_b": "failed"} \
        in verdict["verdicts_differ"]
    baseline = next(p for p in result["points"] if p["test_id"] == BASELINE)["pk_pk_pu"]
    assert baseline["difference"] > 10 * baseline["u_difference"]
    text = _hil("compare", bench_and_twin["ids"]["twin"], fault_id, "--records", str(records))
    assert "NOT reproduced: 7 of 7 judged point(s) differ beyond U_d" in text
    assert f"  beyond U_d: {BASELINE}" in text
