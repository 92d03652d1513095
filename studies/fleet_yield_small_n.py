"""Is ``hil yield --from-db`` honest at small n? (issue 32 item 5)

A simulated fleet: each unit's phase-a current-sensor offset is drawn from the truth
N(TRUE_MEAN_A, TRUE_SIGMA_A²); the diagnosis estimates it with standard uncertainty U_A (the
estimate = offset + N(0, U_A²)). Each unit is one sealed record (``hil.results.synthetic``)
indexed in an SQLite results database, as ``hil db sync`` does. The true yield is the yield of
the tolerance spec with the true distribution (TRUTH_DRIVES closed-form drives).

1. ``hil yield SPEC --from-db`` itself on 3, 10 and 100 units: the predicted yield and its 95 %
   prediction interval (``hil/results/fleet_interval.py``), which must narrow with n.
2. Coverage at n = 10 (and 3, 100): many fleets, each put in a database (rows inserted
   directly, for speed) and fitted as ``--from-db`` does (``fit_parameters`` +
   ``predicted_yield``); the share whose interval holds the true yield.

Run: ``.venv/bin/python studies/fleet_yield_small_n.py [--reps 50]`` → prints the markdown
written to ``studies/results/fleet_yield_small_n.md``.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from contextlib import redirect_stdout
from io import StringIO
from pathlib import Path

import numpy as np

TRUE_MEAN_A, TRUE_SIGMA_A, U_A = 0.05, 0.25, 0.03
TRUTH_DRIVES = 400_000
SPEC = """
drives = 4000
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


def true_yield(spec) -> float:
    from hil.results.fleet_interval import spec_yield
    from hil.results.fleet_yield import fitted_spec

    truth = {"ia_offset_a": {"mean": TRUE_MEAN_A, "sigma": TRUE_SIGMA_A}}
    return spec_yield(fitted_spec(spec, truth), np.random.default_rng(12345), TRUTH_DRIVES)


def fleet_database(root: Path, n: int, rng: np.random.Generator) -> str:
    """n units' records (diagnosis estimate of ia_offset_a) indexed in a fresh SQLite file."""
    from hil.results.db import engine_for
    from hil.results.ingest import sealed_records, sync
    from hil.results.synthetic import point_entry, synthetic_record

    for k in range(n):
        estimate = float(rng.normal(TRUE_MEAN_A, TRUE_SIGMA_A) + rng.normal(0.0, U_A))
        synthetic_record(root / "records", [point_entry(0, 0.02, 0.0007,
                                                        requirement=("REQ-12", 3.0))],
                         dut_serial=f"U-{k:04d}", diagnosis={"ia_offset_a": (estimate, U_A)})
    url = f"sqlite:///{root / 'results.sqlite'}"
    sync(engine_for(url), sealed_records(root / "records"))
    return url


def cli_run(spec_path: Path, url: str, out: Path) -> dict:
    from hil.cli import main

    buffer = StringIO()
    with redirect_stdout(buffer):
        code = main(["yield", str(spec_path), "--from-db", "--results-db", url, "--scheduler",
                     "inline", "--sobol-n", "0", "--out", str(out), "--no-progress", "--json"])
    assert code == 0, code
    return json.loads(buffer.getvalue())["from_db"]["predicted"]


def estimates_database(n: int, rng: np.random.Generator):
    """The same fleet as :func:`fleet_database`, its rows inserted straight into an in-memory
    database (no record folders: the coverage loop's many fleets)."""
    from sqlalchemy import create_engine

    from hil.results.schema import diagnosis_estimates, metadata, runs

    engine = create_engine("sqlite://")
    metadata.create_all(engine)
    with engine.begin() as connection:
        for k in range(n):
            rid = f"20260101T000000Z-{k:06x}"
            connection.execute(runs.insert(), {
                "record_id": rid, "seal_sha256": "0" * 64, "record_path": "-",
                "status": "complete", "statement": "PASS", "created_utc": "2026-01-01T00:00:00Z",
                "simulated": True, "n_tests": 1, "n_failed": 0, "dut_serial": f"U-{k:04d}",
                "indexed_utc": "2026-01-01T00:00:00Z"})
            estimate = float(rng.normal(TRUE_MEAN_A, TRUE_SIGMA_A) + rng.normal(0.0, U_A))
            connection.execute(diagnosis_estimates.insert(), {
                "record_id": rid, "name": "ia_offset_a", "unit": "A", "estimate": estimate,
                "standard_uncertainty": U_A, "identifiable": True})
    return engine


def coverage(spec, n: int, reps: int, truth: float, seed: int) -> dict:
    from hil.results.fleet_interval import predicted_yield
    from hil.results.fleet_yield import fit_parameters

    rng = np.random.default_rng(seed)
    covered, widths = 0, []
    for rep in range(reps):
        engine = estimates_database(n, rng)
        fits = fit_parameters(engine)
        p = predicted_yield(spec, fits, seed=rep)
        engine.dispose()
        low, high = p["interval95"]
        covered += low <= truth <= high
        widths.append(high - low)
    return {"n": n, "reps": reps, "covered": covered, "median_width": float(np.median(widths))}


def main(argv=None) -> int:
    from hil.tolerance.spec import load_tolerances

    parser = argparse.ArgumentParser()
    parser.add_argument("--reps", type=int, default=50, help="fleets of 10 units")
    parser.add_argument("--reps-other", type=int, default=20, help="fleets of 3 and 100 units")
    args = parser.parse_args(argv)
    start = time.monotonic()
    with tempfile.TemporaryDirectory() as tmp:
        spec_path = Path(tmp) / "spec.toml"
        spec_path.write_text(SPEC)
        spec = load_tolerances(spec_path)
        truth = true_yield(spec)
        cli = {}
        for n in (3, 10, 100):
            folder = Path(tmp) / f"n{n}"
            cli[n] = cli_run(spec_path, fleet_database(folder, n, np.random.default_rng(n)),
                             folder / "campaign")
        cover = [coverage(spec, n, args.reps if n == 10 else args.reps_other, truth,
                          seed=100 + n) for n in (3, 10, 100)]
    lines = ["# `hil yield --from-db` at small n (issue 32 item 5)", "",
             f"Truth: ia_offset_a ~ N({TRUE_MEAN_A} A, {TRUE_SIGMA_A} A), diagnosis u = {U_A} A; "
             f"limit 3 % pk-pk at 500 rpm, 20 A; true yield {100 * truth:.2f} % "
             f"({TRUTH_DRIVES:,} closed-form drives).", "",
             "Command: `.venv/bin/python studies/fleet_yield_small_n.py "
             f"--reps {args.reps} --reps-other {args.reps_other}` ({time.monotonic() - start:.0f} s "
             f"on 2 cores shared with other jobs).", "",
             "## `hil yield --from-db` on one fleet of each size", "",
             "| units | predicted yield | 95 % prediction interval | stated |",
             "|---|---|---|---|"]
    for n, p in cli.items():
        value = f"{100 * p['yield']:.1f} %" if p["yield"] is not None else "not stated"
        lines.append(f"| {n} | {value} | [{100 * p['interval95'][0]:.1f}, "
                     f"{100 * p['interval95'][1]:.1f}] % | {p['stated']} |")
    lines += ["", "## Coverage of the true yield", "",
              "| units | fleets whose interval holds the truth | median width |", "|---|---|---|"]
    for c in cover:
        lines.append(f"| {c['n']} | {c['covered']}/{c['reps']} "
                     f"({100 * c['covered'] / c['reps']:.0f} %) | "
                     f"{100 * c['median_width']:.1f} points |")
    lines += ["", "Before issue 32 the interval printed was the Monte Carlo error of the fitted "
              "point values only (e.g. ±0.1 % from 3 units), whatever n."]
    text = "\n".join(lines) + "\n"
    Path(__file__).with_name("results").joinpath("fleet_yield_small_n.md").write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
