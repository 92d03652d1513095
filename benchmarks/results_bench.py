"""Benchmark of the results database: ingest of a 53-test run, and ``hil history`` /
``hil trend`` queries over a synthetic fleet of 10,000 runs, on SQLite and PostgreSQL.

Run: ``.venv/bin/python benchmarks/results_bench.py [--runs 10000] [--quick]``.

* ingest: a sealed synthetic record of 53 measured points (captures of 3960 samples, as the
  simulated bench writes them) indexed by ``ingest_record`` into a database already open (its
  schema migrated): load, integrity check (every capture re-hashed), overall statement, rows, one
  transaction. Median of 5 records.
* queries: 10,000 runs × 5 points, each with a requirement verdict, inserted in bulk (rows made
  by the same ``hil.results.extract`` functions from synthetic record dicts); then
  ``history(limit=50)``, ``history(dut=…)``, ``trend(requirement=…)`` over every run and
  ``trend(source=…)`` over every run; best of 3 each. PostgreSQL: a throw-away local server
  (``hil.results.pg_server``), skipped with a line when the machine has none.
"""

from __future__ import annotations

import argparse
import statistics
from datetime import datetime, timedelta
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

from hil.results import extract  # noqa: E402
from hil.results.db import dispose_all, engine_for  # noqa: E402
from hil.results.ingest import ingest_record  # noqa: E402
from hil.results.queries import history, trend  # noqa: E402
from hil.results.schema import points, requirement_verdicts, runs  # noqa: E402
from hil.results.synthetic import point_entry, synthetic_record  # noqa: E402


START = datetime(2026, 1, 1)


class _Statement:
    overall, reason = "PASS", "synthetic"


def _fleet_rows(n_runs: int, points_per_run: int = 5, seed: int = 1):
    rng = np.random.default_rng(seed)
    run_rows, point_rows, req_rows = [], [], []
    for n in range(n_runs):
        record_id = f"2026{n // 86400 % 12 + 1:02d}01T{n % 86400:06d}Z-{n:06x}"
        tests = [point_entry(i, float(rng.normal(0.024, 0.002)), 0.0007,
                             requirement=("REQ-12", 3.0), tolerance=(0.018, 0.030))
                 for i in range(points_per_run)]
        record = {"record_id": record_id, "status": "complete",
                  "created_utc": (START + timedelta(seconds=600 * n)).strftime(
                      "%Y-%m-%dT%H:%M:%SZ"), "tests": tests,
                  "run": {"dut_serial": f"SN-{n % 2000:05d}", "station": f"st-{n % 8}"},
                  "instruments": [{"role": "drive", "identity": {"firmware": f"1.{n % 5}"}}]}
        run_rows.append(extract.run_row(record, f"/fleet/{record_id}", "0" * 64, _Statement()))
        point_rows += extract.point_rows(record)
        req_rows += extract.requirement_rows(record)
    return run_rows, point_rows, req_rows


def _best(fn, repeat: int = 3) -> float:
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return min(times)


def bench(name: str, url: str, records: list[Path], n_runs: int) -> None:
    engine = engine_for(url)
    ingest_record(engine, records[0])           # warm: imports, connection pool
    times = []
    for folder in records[1:]:
        start = time.perf_counter()
        assert ingest_record(engine, folder) == "indexed"
        times.append(time.perf_counter() - start)
    print(f"ingest of a 53-test run, {name}: {statistics.median(times):.3f} s "
          f"(median of {len(times)}, warm engine; min {min(times):.3f}, max {max(times):.3f})")
    run_rows, point_rows, req_rows = _fleet_rows(n_runs)
    start = time.perf_counter()
    with engine.begin() as connection:
        for table, rows in ((runs, run_rows), (points, point_rows),
                            (requirement_verdicts, req_rows)):
            for i in range(0, len(rows), 5000):
                connection.execute(table.insert(), rows[i:i + 5000])
    print(f"bulk load of {n_runs} synthetic runs ({len(point_rows)} points), {name}: "
          f"{time.perf_counter() - start:.2f} s")
    print(f"hil history (newest 50 of {n_runs} runs), {name}: "
          f"{_best(lambda: history(engine, limit=50)):.3f} s")
    print(f"hil history --dut (one of 2000 DUTs), {name}: "
          f"{_best(lambda: history(engine, dut='SN-00042')):.3f} s")
    result = trend(engine, requirement="REQ-12")
    assert len(result["observations"]) >= n_runs
    print(f"hil trend --requirement over {len(result['observations'])} runs, {name}: "
          f"{_best(lambda: trend(engine, requirement='REQ-12')):.3f} s "
          f"(Cpk {result['capability']['cpk']:.2f})")
    print(f"hil trend --source over {n_runs} runs, {name}: "
          f"{_best(lambda: trend(engine, source='baseline')):.3f} s")
    dispose_all()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=10_000)
    parser.add_argument("--quick", action="store_true", help="500 runs, 2 records")
    args = parser.parse_args()
    n_runs, n_records = (500, 2) if args.quick else (args.runs, 5)
    from hil.results.pg_server import PostgresServer, pg_bin

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        entries = [point_entry(i, 0.024, 0.0007, requirement=("REQ-12", 3.0),
                               tolerance=(0.018, 0.030)) for i in range(53)]
        made = [synthetic_record(tmp / "records", entries, captures=True)
                for _ in range(2 * (n_records + 1))]
        bench("sqlite", f"sqlite:///{tmp / 'results.sqlite'}", made[:n_records + 1], n_runs)
        if pg_bin() is None:
            print("postgresql: skipped (no PostgreSQL server binary on this machine)")
            return 0
        server = PostgresServer(pg_bin())
        try:
            bench("postgresql", server.new_database(), made[n_records + 1:], n_runs)
        finally:
            server.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
