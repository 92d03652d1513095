"""What the page shows from a record: operator alerts, progress, page 1's statement."""

from __future__ import annotations

from hil.config import default_sim_bench
from hil.record import RunRecord, load_record
from hil.station import view
from ripple_hil_reports.statement import overall_statement

SELF_CHECK = "testplans/test_self_check.py::test_bench_self_check"


def _record(tmp_path, checks_pass: bool, abort: dict | None = None, status="complete"):
    record = RunRecord.create(tmp_path, default_sim_bench(), [],
                              sections={"run": {"selection": {"sources": ["self_check",
                                                                          "baseline"]}}})
    record.add_test({"test_id": SELF_CHECK, "source": "self_check", "kind": "self_check",
                     "outcome": "passed" if checks_pass else "failed",
                     "checks": [{"name": "torque scale", "passed": checks_pass}]})
    record.add_test({"test_id": "testplans/test_baseline.py::test_baseline",
                     "source": "baseline", "kind": "measurement",
                     "outcome": "passed" if abort is None else "not run",
                     "verdict": {"decision": "pass", "reason": "pk-pk within [0, 0.01]"}})
    if abort is not None:
        record.set_section("run", {"abort": abort, "selection": {"sources": ["baseline"]}})
    record.finish(status)
    return load_record(record.path), record.path


def test_a_failed_self_check_is_said_in_operator_words(tmp_path):
    record, _ = _record(tmp_path, checks_pass=False)
    alerts = view.alerts(record)
    assert [a["kind"] for a in alerts] == ["self-check"]
    assert "self-check FAILED" in alerts[0]["text"] and "torque scale" in alerts[0]["detail"]


def test_a_passed_self_check_raises_no_alert(tmp_path):
    record, folder = _record(tmp_path, checks_pass=True)
    assert view.alerts(record) == []
    final = view.final_statement(record, folder)
    statement = overall_statement(record, [])
    assert final["overall"] == statement.overall == "PASS"
    assert final["overall_line"] == ("Overall: PASS (model validation and self-check; no "
                                     "requirements given)")
    assert final["lines"][1] == ["2. Model validation (vs the paper)", "baseline: PASS"]


def test_a_lost_bench_names_the_instrument(tmp_path):
    record, folder = _record(tmp_path, checks_pass=True, status="aborted",
                             abort={"instrument": "daq", "step": "capture",
                                    "error": "no answer within 1 s"})
    alerts = view.alerts(record)
    assert alerts[0]["kind"] == "bench-lost" and "(daq)" in alerts[0]["text"]
    assert alerts[0]["detail"] == "no answer within 1 s"
    final = view.final_statement(record, folder)
    assert final["overall"] == overall_statement(record, []).overall == "NOT STATED"


def test_progress_counts_points_per_plan_against_the_collected_totals(tmp_path):
    record, _ = _record(tmp_path, checks_pass=True)
    rows = {row["source"]: row for row in view.progress(record, {"self_check": 1,
                                                                 "baseline": 3})}
    assert rows["baseline"] == {"source": "baseline", "done": 1, "total": 3, "passed": 1,
                                "bad": 0, "not_run": 0}
    assert [v["decision"] for v in view.verdicts(record)] == [None, "pass"]
    assert view.drive_identity(record) == "ripple-hil simulated CiA 402 drive s/n SIM-DRIVE-1"


def test_a_drive_reporting_another_serial_is_shown(tmp_path):
    from hil.record import instrument_table

    record = {"instruments": instrument_table(default_sim_bench(),
                                              [{"role": "drive", "serial_number": "X9"}])}
    assert view.drive_identity(record) == ("ripple-hil simulated CiA 402 drive s/n SIM-DRIVE-1 "
                                           "(the drive reports X9)")


def test_point_plot_is_valid_svg_of_the_recorded_curves(tmp_path):
    import xml.etree.ElementTree as ElementTree

    import numpy as np

    from hil.station.plots import point_svg

    grid = np.linspace(0, 2 * np.pi, 256, endpoint=False)
    revolutions = [1 + 0.02 * np.sin(6 * grid + k) for k in range(4)]
    entry = {"test_id": "plans::test_point[x]", "measured": {
        "pk_pk_pu": 0.04, "angle_grid_rad": grid.tolist(),
        "sync_average_nm": np.mean(revolutions, axis=0).tolist(),
        "revolution_matrix_nm": [r.tolist() for r in revolutions],
        "orders": [1.0, 6.0, 12.0], "amplitude_nm": [0.0, 0.01, 0.001]}}
    svg = ElementTree.fromstring(point_svg(entry, tmp_path))
    ns = "{http://www.w3.org/2000/svg}"
    assert len(svg.findall(f"{ns}polyline")) == 4 + 1          # revolutions + their average
    stems = svg.find(f"{ns}path").get("d")
    assert stems.count("M") == 3
    assert "pk-pk 4 % of mean torque" in ElementTree.tostring(svg, encoding="unicode")
    missing = ElementTree.fromstring(point_svg({"test_id": "p::t", "measured": {}}, tmp_path))
    assert "no plot: no raw capture" in ElementTree.tostring(missing, encoding="unicode")
