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


def test_deviation_sets_span_the_nameplate_errors_a_real_bench_has():
    """Issue 29: R × 0.85…1.45, L × 0.7…1.15 (saturating), Ke × 0.92…1.04, the loop × 0.8…1.25
    and the transducer × 0.7…1.4 of what the bench file states, and a winding warming 20 %."""
    study = load_study()
    sets = study.DEVIATIONS.values()
    for key, low, high in (("r", 0.85, 1.45), ("l", 0.7, 1.15), ("ke", 0.92, 1.04),
                           ("loop", 0.8, 1.25), ("transducer", 0.7, 1.4)):
        values = [d[key] for d in sets if key in d]
        assert min(values) == pytest.approx(low) and max(values) == pytest.approx(high), key
    assert any("l_sat_at" in d for d in sets) and any("warming_pu" in d for d in sets)
    assert len(study.DEVIATION_MOTORS) >= 3
    assert all(len(study.deviation_grid(name)) >= 6 for name in study.DEVIATION_MOTORS)


@pytest.mark.parametrize("deviation", ["warm_saturated", "warming", "cold_fast"])
def test_a_deviation_is_the_bench_files_physics_not_its_nameplate(tmp_path, deviation):
    """The bench copy keeps the motor's nameplate in [motor] and puts the deviation in
    [simulation.actual], which the loader accepts; the saturation current is set at 20 A, the
    warming at the point's current."""
    from hil.config import load_bench

    study = load_study()
    path = study.bench_copy("p8_48v", -500.0, 20.0, tmp_path, deviation)
    config = load_bench(path)
    stated = study.motor_parameters("p8_48v")
    assert config.motor.phase_resistance_ohm == stated.phase_resistance_ohm
    dev = study.DEVIATIONS[deviation]
    actual = config.sim_actual
    assert actual["phase_resistance_ohm"] == pytest.approx(stated.phase_resistance_ohm * dev["r"])
    assert actual["ke_v_s_per_rad"] == pytest.approx(stated.ke_v_s_per_rad * dev["ke"])
    low_point = study.bench_table("p8_48v", 250.0, 5.0, deviation)["simulation"]["actual"]
    assert low_point == actual           # the motor, whatever the point's current
    if "l_sat_at" in dev:     # set at 20 A
        assert actual["saturation_current_a"] == pytest.approx(20.0 * dev["l_sat_at"])
    if "warming_pu" in dev:   # the steady rise at 20 A (copper loss ∝ I²)
        assert actual["winding_rise_pu_per_a2"] * 20.0 ** 2 == pytest.approx(dev["warming_pu"])
