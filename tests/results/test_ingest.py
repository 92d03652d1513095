"""Indexing sealed records: rows as recorded, idempotent on the record ID, sync of what is
missing, a database that is down never fails the run, URL precedence, export."""

from __future__ import annotations

import json
import time

import pytest
from sqlalchemy import func, select

from hil.config import default_sim_bench
from hil.errors import HilError, InputError
from hil.record import RunRecord, load_record, verify_record
from hil.results import index_after_run, verify_row
from hil.results.db import ENV_VAR, engine_for, resolve_url
from hil.results.ingest import ingest_record, sealed_records, sync
from hil.results.schema import (diagnosis_estimates, point_orders, points,
                                requirement_verdicts, runs)
from hil.results.synthetic import synthetic_record, point_entry


def _count(engine, table) -> int:
    with engine.connect() as connection:
        return connection.execute(select(func.count()).select_from(table)).scalar()


def test_a_record_is_indexed_once_with_its_values(tmp_path, sqlite_url):
    folder = synthetic_record(tmp_path / "records", [
        point_entry(0, 0.021, 0.0007, requirement=("REQ-01", 3.0), tolerance=(0.02, 0.04)),
        point_entry(1, 0.052, 0.0008, requirement=("REQ-01", 3.0))],
        dut_serial="SN-7", firmware="1.4.0", diagnosis={"ia_offset_a": (0.21, 0.01)})
    engine = engine_for(sqlite_url)
    assert ingest_record(engine, folder) == "indexed"
    assert ingest_record(engine, folder) == "present"
    with engine.connect() as connection:
        run = connection.execute(select(runs)).one()
        pts = connection.execute(select(points).order_by(points.c.test_id)).all()
        reqs = connection.execute(select(requirement_verdicts)).all()
    seal = (folder / "record.sha256").read_text().split()[0]
    assert (run.record_id, run.seal_sha256, run.dut_serial, run.drive_firmware, run.station) == (
        load_record(folder)["record_id"], seal, "SN-7", "1.4.0", "station-1")
    assert run.statement == "FAIL" and run.n_failed == 1     # point 1: 5.2 % > 3 %, REQ-01 not met
    assert [p.pk_pk_pu for p in pts] == [0.021, 0.052]
    assert [p.pk_pk_u_pu for p in pts] == [0.0007, 0.0008]
    assert [r.accepted for r in sorted(reqs, key=lambda r: r.measured)] == [True, False]
    assert _count(engine, point_orders) == 4 and _count(engine, diagnosis_estimates) == 1
    assert verify_row(folder, sqlite_url) == []


def test_sync_indexes_only_what_is_missing_and_refuses_unsealed(tmp_path, sqlite_url):
    root = tmp_path / "records"
    first = synthetic_record(root, [point_entry(0, 0.03, 0.001)])
    engine = engine_for(sqlite_url)
    ingest_record(engine, first)
    second = synthetic_record(root, [point_entry(0, 0.04, 0.001)])
    unsealed = RunRecord.create(root, default_sim_bench(), [])
    result = sync(engine, sealed_records(root))
    assert result.indexed == [str(second)] and result.present == 1 and not result.failed
    assert _count(engine, runs) == 2
    with pytest.raises(InputError, match="no sealed record"):
        ingest_record(engine, unsealed.path)


def test_a_record_changed_after_indexing_is_reported_not_overwritten(tmp_path, sqlite_url):
    folder = synthetic_record(tmp_path, [point_entry(0, 0.03, 0.001)])
    engine = engine_for(sqlite_url)
    ingest_record(engine, folder)
    record_json = folder / "record.json"
    record_json.write_text(record_json.read_text().replace('"complete"', '"aborted"', 1))
    problems = verify_row(folder, sqlite_url)
    assert any("hashes to" in p for p in problems) and any("status" in p for p in problems)
    (folder / "record.sha256").write_text("0" * 64 + "  record.json\n")
    with pytest.raises(HilError, match="the folder is the truth"):
        ingest_record(engine, folder)
    assert _count(engine, runs) == 1


def test_a_database_that_is_down_never_fails_the_run(tmp_path, capsys):
    folder = synthetic_record(tmp_path / "records", [point_entry(0, 0.03, 0.001)])
    import socket

    with socket.socket() as sock:            # a port nothing listens on
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    start = time.perf_counter()
    assert index_after_run(folder, f"postgresql://nobody@127.0.0.1:{port}/none") is False
    assert time.perf_counter() - start < 5.5
    assert "not indexed" in capsys.readouterr().err
    assert verify_record(folder) == []       # the record is untouched
    url = f"sqlite:///{tmp_path / 'records' / 'results.sqlite'}"
    assert sync(engine_for(url), sealed_records(tmp_path / "records")).indexed == [str(folder)]
    assert index_after_run(folder) is True   # default database beside the records: present
    assert index_after_run(folder, "off") is False and "not indexed" not in capsys.readouterr().err


def test_index_after_run_never_raises_on_a_broken_record(tmp_path, capsys):
    folder = tmp_path / "not-a-record"
    folder.mkdir()
    assert index_after_run(folder, f"sqlite:///{tmp_path / 'r.sqlite'}") is False
    assert "not indexed" in capsys.readouterr().err


def test_url_precedence(tmp_path, monkeypatch):
    bench = tmp_path / "bench.toml"
    bench.write_text('[results]\nurl = "postgresql://lab@db.example/results"\n')
    monkeypatch.delenv(ENV_VAR, raising=False)
    assert resolve_url(None, None, tmp_path) == f"sqlite:///{tmp_path / 'results.sqlite'}"
    assert resolve_url(None, bench, tmp_path) == "postgresql+psycopg://lab@db.example/results"
    monkeypatch.setenv(ENV_VAR, "postgresql://env@h/db")
    assert resolve_url(None, bench, tmp_path) == "postgresql+psycopg://env@h/db"
    assert resolve_url("x.sqlite", bench, tmp_path).endswith("/x.sqlite")


def test_off_in_the_bench_file_is_off(tmp_path, monkeypatch):
    """``[results] url = "off"`` switches indexing off like ``--results-db off`` (it had become
    the SQLite file ``<cwd>/off``)."""
    from hil.results.db import is_disabled

    bench = tmp_path / "bench.toml"
    bench.write_text('[results]\nurl = "off"\n')
    monkeypatch.delenv(ENV_VAR, raising=False)
    assert is_disabled(resolve_url(None, bench, tmp_path))
    assert not is_disabled(resolve_url(None, None, tmp_path))


def test_export_csv_and_parquet(tmp_path, sqlite_url):
    from hil.results.export import export_tables

    engine = engine_for(sqlite_url)
    ingest_record(engine, synthetic_record(tmp_path, [point_entry(0, 0.03, 0.001),
                                                      point_entry(1, 0.04, 0.001)]))
    written = export_tables(engine, tmp_path / "out", "csv")
    assert written[str(tmp_path / "out" / "points.csv")] == 2
    lines = (tmp_path / "out" / "points.csv").read_text().splitlines()
    assert lines[0].startswith("id,record_id,test_id") and len(lines) == 3
    try:
        import pyarrow  # noqa: F401
    except ImportError:
        with pytest.raises(InputError, match="needs pyarrow"):
            export_tables(engine, tmp_path / "pq", "parquet")
    else:
        assert export_tables(engine, tmp_path / "pq", "parquet")[
            str(tmp_path / "pq" / "runs.parquet")] == 1


def test_db_commands(tmp_path, capsys):
    from hil.cli import main

    root = tmp_path / "records"
    first = synthetic_record(root, [point_entry(0, 0.03, 0.001)])
    synthetic_record(root, [point_entry(0, 0.04, 0.001)])
    db = ["--results-db", str(tmp_path / "r.sqlite"), "--json"]
    capsys.readouterr()
    assert main(["db", "import", str(first), *db]) == 0
    assert len(json.loads(capsys.readouterr().out)["indexed"]) == 1
    assert main(["db", "sync", "--records", str(root), *db]) == 0
    out = json.loads(capsys.readouterr().out)
    assert len(out["indexed"]) == 1 and out["present"] == 1
    assert main(["db", "verify", str(first), *db]) == 0
    assert json.loads(capsys.readouterr().out)["agrees"] is True
    assert main(["db", "export", "--format", "csv", "-o", str(tmp_path / "x"), *db]) == 0
    assert json.loads(capsys.readouterr().out)["files"][str(tmp_path / "x" / "runs.csv")] == 2
    assert main(["db", "import", str(tmp_path), *db]) == 2        # not a record folder
