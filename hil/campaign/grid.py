"""``run_grid``: the runs of a regression grid on Dask, each a sealed record, resumable.

The client (this process) submits every run not done yet to the cluster (an embedded
LocalCluster by default, an existing one by ``scheduler`` address: :func:`hil.campaign.engine.
dask_client`); a worker runs it as a normal ``hil run`` (:func:`hil.campaign.grid_run.
execute_run`) and returns the record. The client writes each record as it arrives, once::

    FOLDER/runs/<key>/record/    the sealed run record (record.json, captures/, journal, seal)
    FOLDER/runs/<key>/run.json   the run's grid coordinates, plans, seed, exit status, wall time
    FOLDER/failed/<key>.json     a run that left no record (its output's tail); retried on rerun

``<key>`` is the run's identity (:func:`hil.campaign.grid_spec.run_key`); the folder is written
under a temporary name and renamed, so a run is either done or absent. A rerun skips every done
key — after Ctrl-C, a crash of this process or a killed worker (Dask runs a lost task again
elsewhere; its record is written once, when its one result arrives). A run whose record ended
other than ``complete`` (e.g. ``aborted``: the bench was lost) is done and says so in the
summary; deleting its ``runs/<key>`` folder makes the next rerun measure it again. Each record is indexed in
the results database as it is written, and all done ones again at the end (idempotent: a
record already indexed is left as it is).
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import shutil
import sys
import tarfile
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Sequence

from hil.campaign.grid_spec import GridRun
from hil.errors import InputError

RUN_FILE = "run.json"


class GridInterrupted(KeyboardInterrupt):
    """Ctrl-C during a grid: pending runs cancelled, finished ones kept in the folder."""

    def __init__(self, folder: Path, done: int, total: int) -> None:
        super().__init__(f"grid stopped: {done} of {total} runs kept in {folder} "
                         "(rerun the same command to finish it)")
        self.folder, self.done, self.total = folder, done, total


@dataclass
class GridResult:
    """What the grid holds now, and what this call did."""

    rows: list[dict]
    computed: list[str] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)
    failed: list[str] = field(default_factory=list)
    indexed: int = 0
    workers: int = 0
    wall_s: float = 0.0
    folder: Path = Path(".")


def run_folder(folder: Path, key: str) -> Path:
    return Path(folder) / "runs" / key


def done_keys(folder: Path) -> set[str]:
    """Keys whose record folder was written whole."""
    runs = Path(folder) / "runs"
    return {p.name for p in runs.iterdir() if (p / RUN_FILE).exists()} if runs.exists() \
        else set()


def store_result(folder: Path, run: GridRun, result: dict) -> bool:
    """Write a worker's result once (temp folder + rename); False if it left no record (its
    output goes to ``failed/``) or the key was already written."""
    folder = Path(folder)
    target = run_folder(folder, run.key)
    if (target / RUN_FILE).exists():
        return False
    meta = {"key": run.key, "name": run.name, "labels": run.labels,
            "sources": list(run.sources), "seed": run.seed,
            "exit_status": result["exit_status"], "seconds": round(result["seconds"], 2),
            "worker_pid": result["worker_pid"]}
    if result["record_tar"] is None:
        failed = folder / "failed"
        failed.mkdir(parents=True, exist_ok=True)
        (failed / f"{run.key}.json").write_text(json.dumps(meta | {"output": result["output"]},
                                                           indent=1))
        return False
    tmp = target.parent / f".{run.key}-{os.getpid()}"
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir(parents=True)
    with tarfile.open(fileobj=io.BytesIO(result["record_tar"]), mode="r") as tar:
        tar.extractall(tmp, filter="data")
    (tmp / RUN_FILE).write_text(json.dumps(meta, indent=1))
    os.replace(tmp, target)
    (folder / "failed" / f"{run.key}.json").unlink(missing_ok=True)
    return True


def run_grid(runs: Sequence[GridRun], folder: str | Path, *, scheduler: str | None = None,
             n_workers: int | None = None, results_db: str | None = None,
             progress: bool = True, client: Any = None,
             on_run: Callable[[GridRun, dict], None] | None = None) -> GridResult:
    """Run every run of ``runs`` not done in ``folder``; index the records; the grid's rows."""
    from tqdm import tqdm

    from hil.campaign.engine import dask_client

    if not runs:
        raise InputError("a grid needs at least one run")
    folder = Path(folder)
    (folder / "runs").mkdir(parents=True, exist_ok=True)
    by_key = {run.key: run for run in runs}
    done = done_keys(folder)
    skipped = [k for k in by_key if k in done]
    pending = [run for run in runs if run.key not in done]
    start = time.perf_counter()
    computed: list[str] = []
    failed: list[str] = []
    indexed = 0
    workers = 0
    engine = _engine(results_db, folder)
    bar = tqdm(total=len(runs), initial=len(skipped), unit="run", desc="grid",
               disable=not progress, file=sys.stderr, leave=False)

    def finish(run: GridRun, result: dict) -> None:
        nonlocal indexed
        if store_result(folder, run, result):
            computed.append(run.key)
            indexed += _index(engine, run_folder(folder, run.key) / "record")
        elif result["record_tar"] is None:
            failed.append(run.key)
        bar.update(1)
        if on_run is not None:
            on_run(run, result)

    try:
        if pending:
            with contextlib.ExitStack() as stack:
                if client is None:
                    client = stack.enter_context(dask_client(scheduler, n_workers))
                workers = max(1, len(client.scheduler_info().get("workers", {})))
                _run_on_dask(client, pending, finish)
    except KeyboardInterrupt:
        bar.close()
        raise GridInterrupted(folder, len(done_keys(folder) & set(by_key)), len(runs)) from None
    bar.close()
    indexed += _sync(engine, folder)
    rows = [grid_row(folder, run) for run in runs]
    return GridResult(rows=rows, computed=computed, skipped=skipped, failed=failed,
                      indexed=indexed, workers=workers, wall_s=time.perf_counter() - start,
                      folder=folder)


def _run_on_dask(client: Any, pending: list[GridRun],
                 finish: Callable[[GridRun, dict], None]) -> None:
    """Submit the runs, write each as it completes; on any exit cancel what is left."""
    from distributed import as_completed

    from hil.campaign.grid_run import execute_run

    futures = {}
    try:
        for run in pending:
            futures[client.submit(execute_run, run, key=f"hil-grid-run-{run.key}",
                                  pure=False)] = run
        for future in as_completed(list(futures)):
            finish(futures[future], future.result())
    finally:
        if futures:
            client.cancel(list(futures))
        futures.clear()


def _engine(results_db: str | None, folder: Path):
    """The results database's engine (None: off). Default: FOLDER/results.sqlite."""
    from hil.results.db import engine_for, resolve_url

    url = resolve_url(results_db, None, folder)
    return None if url.strip().lower() in ("off", "none") else engine_for(url)


def _index(engine, record: Path) -> int:
    """Index one record (a database fault is reported and left for ``hil db sync``)."""
    if engine is None:
        return 0
    from hil.results.ingest import ingest_record

    try:
        return int(ingest_record(engine, record) == "indexed")
    except Exception as exc:  # noqa: BLE001 - a sink never fails the grid
        print(f"hil campaign: results database: {record.parent.name} not indexed ({exc})",
              file=sys.stderr)
        return 0


def _sync(engine, folder: Path) -> int:
    if engine is None:
        return 0
    from hil.results.ingest import sealed_records, sync

    return len(sync(engine, sealed_records(folder / "runs")).indexed)


def grid_row(folder: Path, run: GridRun) -> dict:
    """One run's line of the summary: its coordinates and what its record states."""
    row = {"key": run.key, "name": run.name, "labels": run.labels,
           "sources": list(run.sources), "state": "pending"}
    target = run_folder(folder, run.key)
    failed = Path(folder) / "failed" / f"{run.key}.json"
    if (target / RUN_FILE).exists():
        from ripple_hil_reports.statement import overall_statement

        from hil.record import load_record

        meta = json.loads((target / RUN_FILE).read_text())
        record = load_record(target / "record")
        row |= {"state": "done", "exit_status": meta["exit_status"], "seconds": meta["seconds"],
                "record": str(target / "record"), "record_status": record.get("status"),
                "outcomes": dict(Counter(t.get("outcome") for t in record.get("tests", []))),
                "overall": overall_statement(record, None).overall}
    elif failed.exists():
        meta = json.loads(failed.read_text())
        row |= {"state": "no record", "exit_status": meta["exit_status"],
                "output": (meta.get("output") or "")[-300:]}
    return row


def summary_table(rows: list[dict]) -> str:
    """The grid's summary as a Markdown table (one line per run, then the outcome totals)."""
    outcomes = sorted({o for row in rows for o in row.get("outcomes", {})})
    head = ["run", "state", "overall", *outcomes, "exit", "wall s"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    total: Counter = Counter()
    for row in rows:
        counts = row.get("outcomes", {})
        total.update(counts)
        state = row["state"] + (f" ({row['record_status']})" if row.get("record_status")
                                not in (None, "complete") else "")
        lines.append("| " + " | ".join([row["name"], state, row.get("overall", ""),
                                         *(str(counts.get(o, 0)) for o in outcomes),
                                         str(row.get("exit_status", "")),
                                         f"{row['seconds']:.0f}" if "seconds" in row else ""])
                     + " |")
    lines.append("| **all** | " + f"{sum(r['state'] == 'done' for r in rows)}/{len(rows)} done"
                 + " | | " + " | ".join(str(total[o]) for o in outcomes) + " | | |")
    return "\n".join(lines)
