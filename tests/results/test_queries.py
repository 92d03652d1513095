"""History, compare and trend on synthetic records whose values are known, the statistics
against their definitions, and the commands' JSON and PNG output."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.stats import beta

from hil.cli import main
from hil.results.capability import capability, control_chart, measured_yield
from hil.results.db import engine_for
from hil.results.ingest import sealed_records, sync
from hil.results.queries import compare, history, trend
from hil.results.synthetic import point_entry, synthetic_record


@pytest.fixture
def fleet(tmp_path, sqlite_url):
    """Two firmware versions on two DUTs; run B moves point 0 by 3 U_d, point 1 by 0.5 U_d."""
    root = tmp_path / "records"
    u = 0.0007
    a = synthetic_record(root, [point_entry(0, 0.0300, u), point_entry(1, 0.0300, u)],
                         dut_serial="SN-1", firmware="1.3")
    b = synthetic_record(root, [point_entry(0, 0.0300 + 3 * math.sqrt(2) * u, u),
                                point_entry(1, 0.0300 + 0.5 * math.sqrt(2) * u, u)],
                         dut_serial="SN-1", firmware="1.4")
    c = synthetic_record(root, [point_entry(0, 0.0310, u)], dut_serial="SN-2", firmware="1.4",
                         station="station-2")
    engine = engine_for(sqlite_url)
    sync(engine, sealed_records(root))
    return engine, root, a.name, b.name, c.name


def test_history_filters(fleet):
    engine, _, a, b, c = fleet
    def ids(**kw):            # runs created within one second have no order between them
        return {r["record_id"] for r in history(engine, **kw)}

    assert ids() == {a, b, c} and ids(dut="SN-1") == {a, b} and ids(firmware="1.4") == {b, c}
    assert ids(station="station-2") == {c} and len(history(engine, limit=2)) == 2


def test_compare_flags_only_what_moved_beyond_u_d(fleet):
    engine, _, a, b, c = fleet
    result = compare(engine, a, b[:-1])                  # a unique prefix names a run
    assert result["changed"] == ["testplans/test_baseline.py::test_baseline[0]"]
    assert result["unchanged"] == ["testplans/test_baseline.py::test_baseline[1]"]
    point0 = result["points"][0]["pk_pk_pu"]
    assert point0["u_difference"] == pytest.approx(math.sqrt(2) * 0.0007)
    assert point0["difference"] / point0["u_difference"] == pytest.approx(3.0)
    # order 1 (synthetic amplitude pk-pk/2, u = U/4 → U_order = U/2): 1.5 U_d vs 0.25 U_d
    assert result["orders_changed"] == [{"test_id": "testplans/test_baseline.py::test_baseline[0]",
                                         "order": 1.0}]
    only = compare(engine, a, c)
    assert only["only_in_a"] == ["testplans/test_baseline.py::test_baseline[1]"]


def test_compare_says_whether_b_reproduces_a_on_the_judged_points(fleet, tmp_path,
                                                                   sqlite_url):
    """The judged points (a verdict in either run) decide: point 0 moved 3 U_d is named with
    its plan; a run against a copy of itself moved 0.5 U_d is reproduced; a point measured with
    no verdict that moved 3 U_d decides nothing."""
    engine, _, a, b, _ = fleet
    moved = compare(engine, a, b)["reproduction"]
    assert moved["beyond_u"] == ["testplans/test_baseline.py::test_baseline[0]"]
    assert moved["within_u"] == ["testplans/test_baseline.py::test_baseline[1]"]
    assert not moved["reproduced"] and moved["plans_beyond_u"] == ["baseline"]
    assert moved["statement"].startswith("NOT reproduced: 1 of 2 judged point(s) differ")

    u = 0.0007
    root = tmp_path / "more"
    unjudged = point_entry(2, 0.0300 + 3 * math.sqrt(2) * u, u)
    unjudged["outcome"] = "measured, no verdict"
    c = synthetic_record(root, [point_entry(1, 0.0300 + 0.5 * math.sqrt(2) * u, u), unjudged])
    d = synthetic_record(root, [point_entry(1, 0.0300, u), point_entry(2, 0.0300, u)
                                | {"outcome": "measured, no verdict"}])
    sync(engine, sealed_records(root))
    same = compare(engine, c.name, d.name)
    assert same["changed"] == ["testplans/test_baseline.py::test_baseline[2]"]
    assert same["reproduction"]["reproduced"]
    assert same["reproduction"]["within_u"] == ["testplans/test_baseline.py::test_baseline[1]"]
    assert same["reproduction"]["statement"].startswith("reproduced within U on every judged")


def test_statistics_against_their_definitions():
    x = [1.0, 1.2, 0.9, 1.1, 1.05, 0.95]
    cap = capability(x, 0.4, 1.6)
    s = np.std(x, ddof=1)
    assert cap["cp"] == pytest.approx(1.2 / (6 * s))
    assert cap["cpk"] == pytest.approx(min(1.6 - np.mean(x), np.mean(x) - 0.4) / (3 * s))
    half = 1.959964 * math.sqrt(1 / 54 + cap["cpk"] ** 2 / 10)      # Bissell, n = 6
    assert cap["cpk_ci"] == pytest.approx([cap["cpk"] - half, cap["cpk"] + half], rel=1e-5)
    assert capability(x, None, 1.6)["cp"] is None               # one-sided: Cpu only
    chart = control_chart(x + [3.0])
    assert chart["beyond"] == [6]
    assert chart["sigma_short"] == pytest.approx(np.mean(np.abs(np.diff(x + [3.0]))) / 1.128)
    yld = measured_yield([True] * 9 + [False])
    assert yld["ci"] == pytest.approx([beta.ppf(0.025, 9, 2), beta.ppf(0.975, 10, 1)])


def test_bissell_interval_covers_the_true_cpk():
    """The 95 % Cpk interval covers the true Cpk in 92-98 % of normal samples of 50."""
    rng = np.random.default_rng(7)
    true_cpk = (1.0 - 0.2) / (3 * 0.2)
    hits = 0
    for _ in range(400):
        lo, hi = capability(rng.normal(0.2, 0.2, 50), None, 1.0)["cpk_ci"]
        hits += lo <= true_cpk <= hi
    assert 0.92 <= hits / 400 <= 0.98


def test_trend_of_a_requirement_over_units(tmp_path, sqlite_url):
    rng = np.random.default_rng(3)
    values = rng.normal(0.024, 0.002, 30)
    root = tmp_path / "records"
    for n, value in enumerate(values):
        synthetic_record(root, [point_entry(0, float(value), 0.0007,
                                            requirement=("REQ-12", 3.0))],
                         dut_serial=f"SN-{n:03d}")
    engine = engine_for(sqlite_url)
    sync(engine, sealed_records(root))
    result = trend(engine, requirement="REQ-12")
    assert sorted(o["value"] for o in result["observations"]) == pytest.approx(
        sorted(100 * values))
    assert result["upper_limit"] == 3.0 and result["lower_limit"] is None
    accepted = int(np.sum(100 * values + 0.07 <= 3.0))
    assert result["measured_yield"]["passed"] == accepted
    assert result["capability"]["cpk"] == pytest.approx(
        (3.0 - np.mean(100 * values)) / (3 * np.std(100 * values, ddof=1)))


def test_commands_json_and_png(fleet, capsys, tmp_path):
    engine, _, a, b, _ = fleet
    common = ["--results-db", engine.url.database, "--json"]
    capsys.readouterr()
    assert main(["history", "--dut", "SN-1", *common]) == 0
    assert {r["record_id"] for r in json.loads(capsys.readouterr().out)["runs"]} == {a, b}
    assert main(["compare", a, b, "-o", str(tmp_path / "c.png"), *common]) == 0
    assert len(json.loads(capsys.readouterr().out)["changed"]) == 1
    assert main(["trend", "--source", "baseline", "-o", str(tmp_path / "t.png"), *common]) == 0
    assert len(json.loads(capsys.readouterr().out)["observations"]) == 3
    assert (tmp_path / "c.png").stat().st_size > 1000 and (tmp_path / "t.png").stat().st_size > 1000
    assert main(["compare", a, "nope", *common]) == 2            # unknown run: input error
    assert "not in the results database" in json.loads(capsys.readouterr().out)["error"]["message"]


def test_compare_does_not_judge_a_point_measured_at_another_operating_point(tmp_path,
                                                                          sqlite_url):
    """Two runs of one test id at other speeds (another bench file's [operating_point]): the
    difference is the point's, not the drive's, so it is shown but neither CHANGED nor
    unchanged (it was counted CHANGED beyond U_d: 18 of a -700 rpm/12 A vs 1000 rpm/30 A
    pair of correct drives)."""
    root = tmp_path / "records"
    u = 0.0007
    moved = point_entry(0, 0.0400, u)
    moved["operating_point"] = {"speed_rpm": -700.0, "current_a": 20.0, "current_angle_rad": 0.0}
    angled = point_entry(1, 0.0300, u)
    angled["operating_point"] = {"speed_rpm": 500.0, "current_a": 20.0, "current_angle_rad": 0.3}
    a = synthetic_record(root, [point_entry(0, 0.0300, u), point_entry(1, 0.0300, u),
                                point_entry(2, 0.0300, u)])
    b = synthetic_record(root, [moved, angled, point_entry(2, 0.0300 + 3 * math.sqrt(2) * u, u)])
    engine = engine_for(sqlite_url)
    sync(engine, sealed_records(root))
    result = compare(engine, a.name, b.name)
    ids = [f"testplans/test_baseline.py::test_baseline[{i}]" for i in range(3)]
    assert result["changed"] == [ids[2]] and result["unchanged"] == []
    assert result["different_point"] == ids[:2]
    first = result["points"][0]
    assert first["pk_pk_pu"]["changed"] is None and first["pk_pk_pu"]["difference"] > 0.009
    assert all(o["changed"] is None for o in first["orders"])
    assert all(o["test_id"] == ids[2] for o in result["orders_changed"])


def test_a_source_trend_charts_one_operating_point(tmp_path, sqlite_url):
    """The same test id measured on two bench files' operating points has two predictions and
    tolerance zones: the trend charts the newest run's point and counts the others (it charted
    all five runs of a -700..1000 rpm set against the median of their zones: Cpk -0.06, yield
    5/5)."""
    root = tmp_path / "records"
    u = 0.0007
    for value in (0.030, 0.031, 0.029):
        synthetic_record(root, [point_entry(0, value, u, tolerance=(0.02, 0.04))])
    elsewhere = point_entry(0, 0.090, u, tolerance=(0.08, 0.10))
    elsewhere["operating_point"] = {"speed_rpm": -700.0, "current_a": 12.0,
                                    "current_angle_rad": 0.0}
    synthetic_record(root, [elsewhere])                          # an older run elsewhere
    import time
    time.sleep(1.1)                                             # created_utc has 1 s steps
    newest = synthetic_record(root, [point_entry(0, 0.030, u, tolerance=(0.02, 0.04))])
    engine = engine_for(sqlite_url)
    sync(engine, sealed_records(root))
    result = trend(engine, source="baseline")
    assert len(result["observations"]) == 4 and result["runs_at_other_points"] == 1
    assert result["observations"][-1]["record_id"] == newest.name
    assert max(o["value"] for o in result["observations"]) == pytest.approx(0.031)
    assert (result["lower_limit"], result["upper_limit"]) == (0.02, 0.04)


def test_a_record_folder_not_in_the_database_is_refused(fleet, tmp_path):
    """`hil compare FOLDER …` with a folder never indexed (or unsealed) compared an empty run:
    every point 'only in B', 'changed beyond U_d: 0', exit 0."""
    from hil.errors import InputError

    engine, root, a, _, _ = fleet
    other = synthetic_record(tmp_path / "elsewhere", [point_entry(0, 0.03, 0.0007)])
    with pytest.raises(InputError, match="not in the results database.*hil db import"):
        compare(engine, str(other), a)
    assert compare(engine, str(root / a), a)["unchanged"]        # an indexed folder works
