"""Against a real PostgreSQL (and the SQLite default): several stations writing at once, a
server killed mid-ingest, a migration from the first schema — each with the records of a full
default ``hil run`` and of a station run among its synthetic ones (``real_runs.py``)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from sqlalchemy import create_engine, func, select, text

from hil.outcome_kinds import MEASURED, NOT_DETERMINABLE
from hil.record import load_record, verify_record
from hil.results import index_after_run
from hil.results.db import engine_for, head_revision, normalise_url, upgrade
from hil.results.ingest import sealed_records, sync
from hil.results.queries import history
from hil.results.schema import point_orders, points, runs
from hil.results.synthetic import point_entry, synthetic_record

from conftest import wait_for
from real_runs import FULL_DUT, STATION_UNIT

STATION = textwrap.dedent("""
    import json, random, sys
    from pathlib import Path
    from hil.results.db import engine_for
    from hil.results.ingest import ingest_record
    url, seed, folders = sys.argv[1], int(sys.argv[2]), json.loads(sys.argv[3])
    random.Random(seed).shuffle(folders)
    engine = engine_for(url)
    print(json.dumps([ingest_record(engine, Path(f)) for f in folders]))
""")


def _records(root: Path, count: int, tests: int = 3) -> list[Path]:
    return [synthetic_record(root, [point_entry(i, 0.03 + 0.001 * n, 0.0007)
                                    for i in range(tests)], dut_serial=f"SN-{n:04d}")
            for n in range(count)]


def _tests_of(folders: list[Path]) -> dict[str, dict[str, str]]:
    """record id → {test id: outcome} as each record itself lists them."""
    records = [json.loads((f / "record.json").read_text()) for f in folders]
    return {r["record_id"]: {t["test_id"]: t["outcome"] for t in r["tests"]} for r in records}


def _expected(folders: list[Path]) -> tuple[int, int, int, int]:
    """The counts of ``_counts`` once every folder is indexed, read off the records."""
    records = [json.loads((f / "record.json").read_text()) for f in folders]
    n_points = sum(len(r["tests"]) for r in records)
    n_orders = sum(len((t.get("measured") or {}).get("top_orders") or [])
                   for r in records for t in r["tests"])
    return len(records), len(records), n_points, n_orders


def _indexed_tests(url: str) -> dict[str, dict[str, str]]:
    engine = create_engine(normalise_url(url))
    with engine.connect() as connection:
        rows = connection.execute(select(points.c.record_id, points.c.test_id,
                                         points.c.outcome)).all()
    engine.dispose()
    out: dict[str, dict[str, str]] = {}
    for row in rows:
        out.setdefault(row.record_id, {})[row.test_id] = row.outcome
    return out


def _runs(url: str, record_id: str) -> list[dict]:
    engine = create_engine(normalise_url(url))
    with engine.connect() as connection:
        rows = connection.execute(select(runs).where(runs.c.record_id == record_id)).all()
    engine.dispose()
    return [row._asdict() for row in rows]


def _counts(url: str) -> tuple[int, int, int, int]:
    engine = create_engine(normalise_url(url))
    with engine.connect() as connection:
        n_runs = connection.execute(select(func.count()).select_from(runs)).scalar()
        distinct = connection.execute(select(func.count(func.distinct(runs.c.record_id)))).scalar()
        n_points = connection.execute(select(func.count()).select_from(points)).scalar()
        n_orders = connection.execute(select(func.count()).select_from(point_orders)).scalar()
    engine.dispose()
    return n_runs, distinct, n_points, n_orders


def _stations(url: str, folders: list[Path], n_processes: int) -> list[list[str]]:
    """Each of ``n_processes`` processes ingests every folder, in its own order, at once."""
    env = os.environ | {"PYTHONPATH": os.pathsep.join(sys.path)}
    procs = [subprocess.Popen([sys.executable, "-c", STATION, url, str(seed),
                               json.dumps([str(f) for f in folders])],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
             for seed in range(n_processes)]
    outs = []
    for proc in procs:
        out, err = proc.communicate(timeout=240)
        assert proc.returncode == 0, err[-2000:]
        outs.append(json.loads(out.strip().splitlines()[-1]))
    return outs


@pytest.mark.parametrize("backend", ["postgresql", "sqlite"])
def test_n_stations_times_m_runs_nothing_lost_nothing_duplicated(backend, tmp_path, request,
                                                                 real_records):
    url = (request.getfixturevalue("pg_url") if backend == "postgresql"
           else request.getfixturevalue("sqlite_url"))
    n_processes = 3
    folders = _records(tmp_path, 3) + real_records.both
    m_runs = len(folders)
    outs = _stations(url, folders, n_processes)
    # every record indexed by exactly one station; the others found it present
    assert sum(o.count("indexed") for o in outs) == m_runs
    assert all(len(o) == m_runs and set(o) <= {"indexed", "present"} for o in outs)
    assert _counts(url) == _expected(folders)
    assert _indexed_tests(url) == _tests_of(folders)


@pytest.mark.parametrize("backend", ["postgresql", "sqlite"])
def test_real_runs_are_indexed_whole(backend, request, real_records):
    """Every test of a full default run and of a station run, with the outcome its record
    states: "measured, no verdict" (20 characters) and "not determinable" included."""
    url = (request.getfixturevalue("pg_url") if backend == "postgresql"
           else request.getfixturevalue("sqlite_url"))
    result = sync(engine_for(url), real_records.both)
    assert result.failed == [] and len(result.indexed) == 2
    indexed = _indexed_tests(url)
    assert indexed == _tests_of(real_records.both)
    full = indexed[load_record(real_records.full)["record_id"]]
    assert MEASURED in full.values()
    assert len(full) >= 60 and set(full.values()) <= {"passed", "failed", MEASURED,
                                                      NOT_DETERMINABLE}
    # the station's scanned unit and the run's --dut-serial are the DUT column (issue 32.2)
    station_id = load_record(real_records.station)["record_id"]
    assert [r["record_id"] for r in history(engine_for(url), dut=STATION_UNIT)] == [station_id]
    assert [r["dut_stated_by"] for r in _runs(url, station_id)] == ["station scan"]
    assert len(history(engine_for(url), dut=FULL_DUT)) == 1


#: records the killed sync works through
KILL_RECORDS = 150


def test_a_server_killed_mid_ingest_loses_nothing(tmp_path, postgres_server, pg_url,
                                                  real_records):
    # enough records that the sync is still working when the server dies (20 were all indexed
    # before the kill once the test processes kept their bytecode caches: a race, not a pass)
    folders = _records(tmp_path / "records", KILL_RECORDS, tests=6)
    for real in real_records.both:        # among them, two that hil run wrote
        shutil.copytree(real, tmp_path / "records" / real.name)
        folders.append(tmp_path / "records" / real.name)
    engine_for(pg_url)                      # schema created before the kill
    env = os.environ | {"PYTHONPATH": os.pathsep.join(sys.path)}
    code = ("import sys; from pathlib import Path\n"
            "from hil.results.db import engine_for\n"
            "from hil.results.ingest import sealed_records, sync\n"
            "r = sync(engine_for(sys.argv[1]), sealed_records(Path(sys.argv[2])))\n"
            "print(len(r.indexed), len(r.failed))\n")
    proc = subprocess.Popen([sys.executable, "-c", code, pg_url, str(tmp_path / "records")],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    try:
        assert wait_for(lambda: _counts(pg_url)[0] >= 3, timeout_s=60)
    finally:
        postgres_server.kill()
    try:
        out, err = proc.communicate(timeout=120)
        assert proc.returncode == 0, err[-2000:]       # the sync process survived the kill
        indexed, failed = map(int, out.split())
        assert indexed >= 3 and failed >= 1 and indexed + failed == KILL_RECORDS + 2
        # a run that ends while the server is down: its record is sealed, indexing gives up
        late = synthetic_record(tmp_path / "records", [point_entry(i, 0.05, 0.0007)
                                                       for i in range(6)])
        assert index_after_run(late, pg_url, timeout_s=5.0) is False
        folders.append(late)
    finally:
        postgres_server.start()             # the session's other tests need it, pass or fail
    n_runs = _counts(pg_url)[0]
    tests = _tests_of(folders)
    assert all(tests[rid] == got for rid, got in _indexed_tests(pg_url).items())  # none half
    assert all(verify_record(f) == [] for f in folders)   # every record intact
    from hil.results.db import dispose_all

    dispose_all()
    result = sync(engine_for(pg_url), sealed_records(tmp_path / "records"))
    assert not result.failed and len(result.indexed) == KILL_RECORDS + 3 - n_runs
    assert _counts(pg_url) == _expected(folders)
    assert _indexed_tests(pg_url) == _tests_of(folders)


@pytest.mark.parametrize("backend", ["postgresql", "sqlite"])
def test_migration_from_the_first_schema(backend, tmp_path, request, real_records):
    url = (request.getfixturevalue("pg_url") if backend == "postgresql"
           else request.getfixturevalue("sqlite_url"))
    engine = create_engine(normalise_url(url))
    upgrade(engine, "0001")
    with engine.begin() as connection:       # a run indexed under the first schema
        connection.execute(text(
            "INSERT INTO runs (record_id, seal_sha256, record_path, status, statement, "
            "created_utc, simulated, n_tests, n_failed, indexed_utc) VALUES ('20250101T000000Z-"
            "aaaaaa', :seal, '/old', 'complete', 'PASS', '2025-01-01T00:00:00Z', :f, 1, 0, "
            "'2025-01-01T00:00:00Z')"), {"seal": "a" * 64, "f": False})
        connection.execute(text(
            "INSERT INTO points (record_id, test_id, outcome, pk_pk_pu, pk_pk_u_pu) VALUES "
            "('20250101T000000Z-aaaaaa', 't::old', 'passed', 0.03, 0.001)"))
        tables = set(connection.dialect.get_table_names(connection))
    assert "point_orders" not in tables and "diagnosis_estimates" not in tables
    engine.dispose()
    migrated = engine_for(url)               # opening migrates to head
    with migrated.connect() as connection:
        assert connection.execute(text("SELECT version_num FROM alembic_version")).scalar() \
            == head_revision()
        assert connection.execute(select(points.c.pk_pk_pu)).scalars().all() == [0.03]
    folder = synthetic_record(tmp_path / "r", [point_entry(0, 0.04, 0.001)])
    assert sync(migrated, [folder, *real_records.both]).indexed == [
        str(f) for f in (folder, *real_records.both)]
    n_runs, distinct, n_points, n_orders = _expected([folder, *real_records.both])
    assert _counts(url) == (n_runs + 1, distinct + 1, n_points + 1, n_orders)
