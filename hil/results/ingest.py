"""Index sealed run records into the results database: a sink that never fails or slows a run.

One record is one transaction keyed on its record ID: it is indexed completely or not at all, and
indexing it again (another station, ``hil db sync`` after a crash, two processes at once) adds
nothing — the second insert of a ``runs`` row violates its primary key, the transaction rolls
back and the record counts as already present. A record whose seal no longer matches the row is
reported, never overwritten (the record folder is the truth; ``verify_row`` says which differs).
"""

from __future__ import annotations

import logging
import threading
from dataclasses import dataclass, field
from pathlib import Path

from hil.errors import HilError, InputError
from hil.record import RECORD_FILE, SEAL_FILE, load_record, verify_record
from hil.results import extract
from hil.results.db import is_disabled
from hil.results.schema import (diagnosis_estimates, point_orders, points, requirement_verdicts,
                                runs)

log = logging.getLogger("hil.results")
#: Seconds ``index_after_run`` lets indexing take before leaving the record to ``hil db sync``.
AFTER_RUN_TIMEOUT_S = 5.0


def record_folder(path: str | Path) -> Path:
    path = Path(path)
    return path.parent if path.name == RECORD_FILE else path


def seal_of(folder: Path) -> str | None:
    """The SHA-256 the seal file states for ``record.json`` (None: not sealed)."""
    try:
        return (folder / SEAL_FILE).read_text(encoding="utf-8").split()[0]
    except (OSError, IndexError):
        return None


def ingest_record(engine, path: str | Path, *, dut_serial: str | None = None) -> str:
    """Index one sealed record: ``"indexed"`` or ``"present"`` (already indexed, same seal).

    Raises :class:`InputError` for a folder that holds no sealed record, :class:`HilError` when
    the database holds this record ID with another seal hash.
    """
    from sqlalchemy import select
    from sqlalchemy.exc import IntegrityError
    from ripple_hil_reports.statement import overall_statement

    folder = record_folder(path)
    seal = seal_of(folder)
    if seal is None:
        raise InputError(f"{folder}: no sealed record ({SEAL_FILE} missing: the run never "
                         "finished, or this is not a record folder)")
    record = load_record(folder)
    if record.get("status") == "running":
        raise InputError(f"{folder}: the record was never finished (status running)")
    with engine.connect() as connection:
        existing = connection.execute(select(runs.c.seal_sha256).where(
            runs.c.record_id == record["record_id"])).scalar()
    if existing is not None:
        return _present(record["record_id"], existing, seal)
    statement = overall_statement(record, verify_record(folder, record))
    rows = [(runs, [extract.run_row(record, str(folder.resolve()), seal, statement,
                                    dut_serial)]),
            (points, extract.point_rows(record)),
            (requirement_verdicts, extract.requirement_rows(record)),
            (point_orders, extract.order_rows(record)),
            (diagnosis_estimates, extract.diagnosis_rows(record))]
    try:
        with engine.begin() as connection:
            for table, values in rows:
                if values:
                    connection.execute(table.insert(), values)
    except IntegrityError:
        with engine.connect() as connection:
            existing = connection.execute(select(runs.c.seal_sha256).where(
                runs.c.record_id == record["record_id"])).scalar()
        if existing is None:
            raise
        return _present(record["record_id"], existing, seal)
    return "indexed"


def _present(record_id: str, indexed_seal: str, seal: str) -> str:
    if indexed_seal != seal:
        raise HilError(f"record {record_id}: the database holds it with seal {indexed_seal[:12]}…, "
                       f"the folder's seal is {seal[:12]}…; the folder is the truth: check it "
                       "with 'hil verify'")
    return "present"


def sealed_records(root: str | Path) -> list[Path]:
    """Record folders under ``root`` (any depth) that hold a seal, oldest name first."""
    root = Path(root)
    if (root / SEAL_FILE).exists():
        return [root]
    return sorted(p.parent for p in root.rglob(SEAL_FILE))


@dataclass
class SyncResult:
    indexed: list[str] = field(default_factory=list)
    present: int = 0
    failed: list[tuple[str, str]] = field(default_factory=list)

    def to_dict(self) -> dict:
        return {"indexed": self.indexed, "present": self.present,
                "failed": [{"record": r, "error": e} for r, e in self.failed]}


def sync(engine, folders: list[Path], *, dut_serial: str | None = None) -> SyncResult:
    """Index each folder not yet in the database; a bad record is listed, the others go on."""
    from sqlalchemy import select
    from sqlalchemy.exc import SQLAlchemyError

    result = SyncResult()
    with engine.connect() as connection:
        known = set(connection.execute(select(runs.c.record_path)).scalars())
    for folder in folders:
        if str(folder.resolve()) in known:
            result.present += 1
            continue
        try:
            outcome = ingest_record(engine, folder, dut_serial=dut_serial)
        except (HilError, OSError, ValueError, SQLAlchemyError) as exc:
            result.failed.append((str(folder), str(exc).strip().splitlines()[0][:300]))
            continue
        if outcome == "indexed":
            result.indexed.append(str(folder))
        else:
            result.present += 1
    return result


def index_after_run(record_dir: str | Path, url: str | None = None, *,
                    bench_file: str | Path | None = None,
                    timeout_s: float = AFTER_RUN_TIMEOUT_S) -> bool:
    """Index a record just sealed by ``hil run``; never raises, never holds the run longer than
    ``timeout_s``. ``url``: the ``--results-db`` value (None: ``hil.results.db.resolve_url``'s
    rule with ``bench_file`` and the record's parent folder; ``off``: do nothing). True when
    indexed (or already present); otherwise one warning line (logged and on stderr) and the
    record stays for ``hil db sync``."""
    import sys

    if url is not None and is_disabled(url):
        return False
    outcome: list = []

    def work() -> None:
        try:
            from hil.results.db import engine_for, resolve_url

            folder = record_folder(record_dir)
            target = resolve_url(url, bench_file, folder.parent)
            if is_disabled(target):
                outcome.append("disabled")
                return
            outcome.append(ingest_record(engine_for(target), folder))
        except BaseException as exc:   # noqa: BLE001 - a sink must never fail the run
            outcome.append(exc)

    worker = threading.Thread(target=work, name="hil-results-index", daemon=True)
    worker.start()
    worker.join(timeout_s)
    if outcome and isinstance(outcome[0], str):
        return outcome[0] != "disabled"
    reason = (f"took longer than {timeout_s:g} s" if not outcome
              else f"{type(outcome[0]).__name__}: {str(outcome[0]).splitlines()[0][:200]}")
    message = (f"hil: results database: record {record_folder(record_dir).name} not indexed "
               f"({reason}); the record is intact, 'hil db sync' indexes it later")
    log.warning(message)
    print(message, file=sys.stderr)
    return False


def verify_row(record_dir: str | Path, url: str) -> list[str]:
    """Problems between a record folder and its database row (empty: they agree): no row, a
    seal that differs, a ``record.json`` that no longer hashes to its row's seal."""
    import hashlib

    from sqlalchemy import select

    from hil.results.db import engine_for

    folder = record_folder(record_dir)
    record = load_record(folder)
    with engine_for(url).connect() as connection:
        row = connection.execute(select(runs.c.seal_sha256, runs.c.status).where(
            runs.c.record_id == record["record_id"])).first()
    if row is None:
        return [f"record {record['record_id']} is not in the results database"]
    problems = []
    seal = seal_of(folder)
    if seal != row.seal_sha256:
        problems.append(f"{SEAL_FILE} states {seal}, the database row {row.seal_sha256}")
    actual = hashlib.sha256((folder / RECORD_FILE).read_bytes()).hexdigest()
    if actual != row.seal_sha256:
        problems.append(f"{RECORD_FILE} hashes to {actual}, the database row states "
                        f"{row.seal_sha256}")
    if record.get("status") != row.status:
        problems.append(f"status {record.get('status')!r} in the record, {row.status!r} in the "
                        "database")
    return problems
