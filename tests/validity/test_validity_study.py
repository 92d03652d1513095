"""The reduced validity study (studies/validity.py --reduced): the correct simulated drive, run
as a user runs it (``hil run --bench COPY``) on Table I in reverse rotation and on an 8-pole 48 V
motor, every plan: no wrong rejection (a failed verdict on a correct drive), no error, and every
refusal carries its reason. It runs as a regression grid (``studies/validity.py --reduced
--dask``) on a 1-worker LocalCluster: two whole runs side by side on CI's 2 cores, with the
bench's own timeouts, are what the simulated instruments' timing must not depend on; the
2-worker grid is tests/campaign/test_grid_dask.py's and the study's
(studies/results/validity_grid.md). ``pytest -m validity_study`` selects it."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

STUDY = Path(__file__).parents[2] / "studies" / "validity.py"


def load_study():
    spec = importlib.util.spec_from_file_location("validity_study", STUDY)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.validity_study
@pytest.mark.slow
def test_reduced_validity_study_has_no_wrong_rejection(tmp_path):
    study = load_study()
    rows = study.run_on_dask(study.REDUCED, [], tmp_path / "grid", None, 1)
    table = study.markdown(rows)
    assert [(r["motor"], (r["speed_rpm"], r["current_a"])) for r in rows] == study.REDUCED
    assert all("run_error" not in row for row in rows), table
    tests = [t for row in rows for t in row["tests"]]
    assert len(tests) > 40, table                      # every plan ran (not an empty record)
    categories = {t["category"] for t in tests}
    assert study.PASS in categories
    assert not [t for t in tests if t["category"] in (study.WRONG, study.ERROR)], table
    assert all(t["reason"] for t in tests if t["category"] == study.NOT_DET), table


def test_study_grid_has_three_buses_uneven_pole_counts_and_twelve_points_each_both_directions():
    study = load_study()
    assert len(study.MOTORS) >= 3
    poles = {study.motor_parameters(name).pole_count for name in study.MOTORS}
    buses = {study.motor_parameters(name).dc_bus_v for name in study.MOTORS}
    assert len(poles) >= 3 and len(buses) >= 3
    # issue 30: a pole count whose count order does not divide the 7200-count encoder
    assert {10, 14} <= poles
    for name in study.MOTORS:
        points = study.grid(name)
        assert len(points) >= 12
        assert any(s < 0 for s, _ in points) and any(s > 0 for s, _ in points)
        assert min(i for _, i in points) <= 5.0


def test_classify_keeps_each_kind_apart():
    study = load_study()
    assert study.classify({"outcome": "failed", "message": "x"}) == (study.WRONG, "x")
    assert study.classify({"outcome": "skipped",
                           "message": "not determinable here: voltage headroom: 7 V vs 6.9 V"}) \
        == (study.NOT_DET, "voltage headroom: 7 V vs 6.9 V")
    # the record states "measured, no verdict" for a point without a rule; a test that passed
    # asserted something (the diagnosis plan's fit and standard additions have no verdict field)
    assert study.classify({"outcome": "measured, no verdict", "kind": "ripple_map"})[0] \
        == study.MEASURED
    assert study.classify({"outcome": "passed", "kind": "diagnosis", "verdict": None,
                           "requirements": []})[0] == study.PASS
    assert study.classify({"outcome": "passed", "kind": "measurement",
                           "verdict": {"x": 1}})[0] == study.PASS
    assert study.classify({"outcome": "error", "error": "boom"}) == (study.ERROR, "boom")
