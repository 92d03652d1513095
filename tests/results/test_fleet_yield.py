"""``hil yield --from-db``: tolerances fitted to diagnosed units (the estimates' own scatter
removed), predicted yield beside the units' measured yield."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from hil.cli import main
from hil.results.db import engine_for
from hil.results.fleet_yield import fit_parameters, unit_yield
from hil.results.ingest import sealed_records, sync
from hil.results.synthetic import point_entry, synthetic_record

TOLERANCES = """
drives = 20000
seed = 3
[requirement]
id = "REQ-12"
name = "pk-pk ripple at most 3 %"
quantity = "pk_pk_pct"
limit = { max = 3.0 }
[[operating_point]]
speed_rpm = 500
current_a = 20
current_angle_deg = 0
[parameters.ia_offset_a]
distribution = "normal"
sigma = 0.5
"""


@pytest.fixture(scope="module")
def diagnosed_fleet(tmp_path_factory):
    """24 units: ia offset N(0.05 A, 0.10 A) estimated with u = 0.03 A; 19 accepted REQ-12."""
    from hil.results.db import dispose_all

    tmp_path = tmp_path_factory.mktemp("fleet")
    sqlite_url = f"sqlite:///{tmp_path / 'results.sqlite'}"
    rng = np.random.default_rng(11)
    root = tmp_path / "records"
    truth = rng.normal(0.05, 0.10, 24)
    for n, offset in enumerate(truth):
        estimate = float(offset + rng.normal(0.0, 0.03))
        synthetic_record(root, [point_entry(0, 0.02 if n < 19 else 0.05, 0.0007,
                                            requirement=("REQ-12", 3.0))],
                         dut_serial=f"SN-{n:03d}",
                         diagnosis={"ia_offset_a": (estimate, 0.03),
                                    "ib_offset_a": (float(rng.normal(0, 0.1)), 0.03)})
    engine = engine_for(sqlite_url)
    sync(engine, sealed_records(root))
    yield engine, truth
    dispose_all()


def test_fit_removes_the_estimates_scatter(diagnosed_fleet):
    engine, truth = diagnosed_fleet
    fit = fit_parameters(engine)["ia_offset_a"]
    assert fit["units"] == 24 and fit["mean_u"] == pytest.approx(0.03)
    assert fit["sigma"] == pytest.approx(math.sqrt(fit["s"] ** 2 - 0.03 ** 2))
    assert fit["sigma"] < fit["s"]
    # σ of 24 draws: ±15 % (1 sd) around 0.10 (fixed seed)
    assert 0.07 < fit["sigma"] < 0.13 and abs(fit["mean"] - 0.05) < 0.05
    assert unit_yield(engine, "REQ-12")["passed"] == 19


def test_yield_from_db_prints_predicted_beside_measured(diagnosed_fleet, tmp_path, capsys):
    engine, _ = diagnosed_fleet
    spec = tmp_path / "tol.toml"
    spec.write_text(TOLERANCES)
    capsys.readouterr()
    assert main(["yield", str(spec), "--from-db", "--results-db", engine.url.database,
                 "--scheduler", "inline", "--sobol-n", "0", "--out", str(tmp_path / "y"),
                 "--no-progress", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    measured = out["from_db"]["measured"]
    assert (measured["passed"], measured["total"]) == (19, 24)
    assert measured["ci"][0] < 19 / 24 < measured["ci"][1]
    assert out["from_db"]["fits"]["ia_offset_a"]["units"] == 24
    # the file's sigma 0.5 A is replaced by the fitted ~0.1 A: far fewer drives fail
    assert 0.0 <= out["yield"] <= 1.0 and out["yield"] > 0.9


def test_yield_from_db_text_names_the_fits(diagnosed_fleet, tmp_path, capsys):
    engine, _ = diagnosed_fleet
    spec = tmp_path / "tol.toml"
    spec.write_text(TOLERANCES)
    capsys.readouterr()
    assert main(["yield", str(spec), "--from-db", "--results-db", engine.url.database,
                 "--scheduler", "inline", "--sobol-n", "0", "--drives", "2000",
                 "--out", str(tmp_path / "y"), "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert "ia_offset_a    24 units" in out and "ib_offset_a    24 units" in out
    assert "measured   79.2 %" in out and "(19/24 units, REQ-12)" in out
