"""Done-when of issue 29's twin, through the real CLI in subprocesses: a twin written by
``hil characterize --write-twin`` from a bench whose physics is not its nameplate (R × 1.3,
L × 0.8, Ke × 0.96, loop × 0.9) reproduces that bench's ``hil run`` within U on every judged
point (``hil compare``), and the same bench with a hidden fault added after the twin was
written (a 0.3 A offset on phase a's current sensor) is named by the compare, point by point
and plan by plan. Reduced plan selection (baseline, dead time, and the self-check every run
has); the full plan set: studies/results/twin_compare.md."""

from __future__ import annotations

import tomllib

import pytest

from studies.twin_compare import DEVIATION, compare, deviated_bench, hil_cli, run_plans

pytestmark = pytest.mark.slow      # characterize + three reduced `hil run`s, one after another

SOURCES = ("baseline", "dead_time")
DEAD_TIME_POINTS = [f"testplans/test_dead_time.py::test_dead_time[dead_time_s={t}]"
                    for t in ("2e-06", "3e-06", "4e-06")]
BASELINE = "testplans/test_baseline.py::test_baseline"
SELF_CHECK = "testplans/test_self_check.py::"
#: The regulated points of the selection, judged in every run (the self-check's always runs).
JUDGED = {BASELINE, *DEAD_TIME_POINTS, *(SELF_CHECK + name for name in (
    "test_bench_self_check", "test_transducer_dynamics", "test_transducer_dynamics-reference"))}


@pytest.fixture(scope="module")
def bench_and_twin(tmp_path_factory):
    """The deviated bench, its twin file, and a run of each (other noise seeds)."""
    root = tmp_path_factory.mktemp("twin")
    bench, twin, records = root / "bench.toml", root / "twin.toml", root / "records"
    stated, actual = deviated_bench(bench)
    hil_cli("characterize", "--bench", str(bench), "--record-dir",
            str(root / "characterisation"), "--write-twin", str(twin))
    ids = {"bench": run_plans(bench, records, 0, SOURCES, ok=(0,)),
           "twin": run_plans(twin, records, 1, SOURCES, ok=(0,))}
    return {"root": root, "bench": bench, "twin": twin, "records": records, "ids": ids,
            "stated": stated, "actual": actual}


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
    result = compare(records, ids["twin"], ids["bench"])           # d = bench − twin
    verdict = result["reproduction"]
    assert verdict["reproduced"], verdict
    assert verdict["beyond_u"] == [] and verdict["verdicts_differ"] == []
    assert set(verdict["within_u"]) == JUDGED
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
    # what the bench hides is found (its transducer is as stated: confirmed, not replaced)
    assert {r["name"] for r in bench_rows if r["disagrees"]} == {
        "phase_resistance_ohm", "phase_inductance_h", "ke_v_s_per_rad",
        "current_loop_bandwidth_hz"}
    twin_rows = {r["name"]: r for r in
                 _record(records, ids["twin"])["characterisation"]["stated_vs_measured"]}
    for row in bench_rows:
        other = twin_rows[row["name"]]
        assert other["stated"] == row["stated"] and other["disagrees"] == row["disagrees"]
        assert abs(other["measured"] - row["measured"]) <= (row["U_k2"] ** 2
                                                            + other["U_k2"] ** 2) ** 0.5, row


def test_a_hidden_fault_the_twin_lacks_is_named(bench_and_twin):
    root, records = bench_and_twin["root"], bench_and_twin["records"]
    faulty = root / "bench-with-fault.toml"
    deviated_bench(faulty, defects={"hidden_ia_offset_a": 0.3})     # after the twin was written
    fault_id = run_plans(faulty, records, 2, SOURCES, ok=(1,))      # its baseline fails
    result = compare(records, bench_and_twin["ids"]["twin"], fault_id)
    verdict = result["reproduction"]
    assert not verdict["reproduced"]
    # a 0.3 A offset (1.5 % of 20 A) adds ~3.4 % pk-pk of order 1 at every regulated point
    assert set(verdict["beyond_u"]) == JUDGED
    assert verdict["plans_beyond_u"] == ["baseline", "dead_time", "self_check"]
    assert {"test_id": BASELINE, "outcome_a": "passed", "outcome_b": "failed"} \
        in verdict["verdicts_differ"]
    baseline = next(p for p in result["points"] if p["test_id"] == BASELINE)["pk_pk_pu"]
    assert baseline["difference"] > 10 * baseline["u_difference"]
    text = hil_cli("compare", bench_and_twin["ids"]["twin"], fault_id, "--records", str(records))
    assert "NOT reproduced: 7 of 7 judged point(s) differ beyond U_d" in text
    assert f"  beyond U_d: {BASELINE}" in text
