"""``run_campaign``: independent chunks of work on Dask distributed, resumable, stoppable.

Each chunk is ``task(spec, seed_sequence) -> {name: array}``, with the chunk's own seed sequence
(:func:`hil.campaign.seeds.chunk_seed`), so results do not depend on the number of workers. The
client (this process) writes every finished chunk to the campaign folder as it arrives
(:class:`~hil.campaign.store.CampaignStore`): workers need no shared file system, a rerun skips
finished chunks, and Ctrl-C cancels the pending futures, closes the cluster and keeps every
chunk already written.

Where the chunks run (``scheduler``):

* ``None`` — an embedded ``LocalCluster``: worker processes (``n_workers``, default the
  machine's cores), one thread each, bound to 127.0.0.1, no dashboard; closed at the end.
* ``"tcp://HOST:8786"`` — an existing Dask cluster (left running at the end).
* ``"inline"`` — this process, one chunk after another (no Dask; same chunks, same seeds).

A ``client`` (a ``distributed.Client``) may be passed instead, to share one cluster between
campaigns (it is left open).
"""

from __future__ import annotations

import contextlib
import logging
import os
import signal
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterator, Sequence

import numpy as np
from tqdm import tqdm

from hil.campaign.seeds import chunk_seed
from hil.campaign.store import CampaignStore
from hil.errors import InputError

Task = Callable[[Any, np.random.SeedSequence], dict]


class CampaignInterrupted(KeyboardInterrupt):
    """Ctrl-C during a campaign: pending chunks cancelled, finished ones kept in the folder."""

    def __init__(self, folder: Path, finished: int, total: int) -> None:
        super().__init__(f"campaign stopped: {finished} of {total} chunks kept in {folder} "
                         "(rerun the same command to finish it)")
        self.folder, self.finished, self.total = folder, finished, total


@dataclass
class CampaignResult:
    """Every chunk's arrays in chunk order, and what this run did."""

    chunks: list[dict[str, np.ndarray]]
    computed: list[int]
    skipped: list[int]
    wall_s: float
    workers: int
    folder: Path
    timings_s: dict[int, float] = field(default_factory=dict)

    def concatenated(self, name: str) -> np.ndarray:
        """Array ``name`` of every chunk joined along the first axis."""
        return np.concatenate([chunk[name] for chunk in self.chunks])


def timed_task(task: Task, spec: Any, seed: np.random.SeedSequence) -> tuple[dict, float]:
    """Run one chunk on a worker; return its arrays and its compute time (s, on the worker)."""
    start = time.perf_counter()
    arrays = task(spec, seed)
    return arrays, time.perf_counter() - start


@contextlib.contextmanager
def dask_client(scheduler: str | None = None, n_workers: int | None = None) -> Iterator[Any]:
    """A ``distributed.Client``: of an embedded LocalCluster, or connected to ``scheduler``."""
    from distributed import Client, LocalCluster

    if scheduler:
        if not str(scheduler).startswith(("tcp://", "tls://", "inproc://")):
            raise InputError(f"--scheduler {scheduler!r} must be an address like "
                             "tcp://HOST:8786 (or 'inline')")
        try:
            client = Client(scheduler, timeout="10s")
        except OSError as exc:
            raise InputError(f"--scheduler {scheduler}: cannot connect ({exc})") from None
        try:
            yield client
        finally:
            client.close()
        return
    workers = (os.cpu_count() or 1) if n_workers is None else n_workers
    if isinstance(workers, bool) or not isinstance(workers, int) or not 1 <= workers <= 1024:
        raise InputError(f"n_workers={n_workers!r} must be an integer in 1..1024")
    # the workers ignore Ctrl-C (they inherit SIG_IGN at spawn): only this process handles it,
    # cancelling the futures and closing the cluster, without a traceback from every worker
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN) \
        if threading.current_thread() is threading.main_thread() else None
    try:
        cluster = _local_cluster(workers, LocalCluster)
    finally:
        if previous is not None:
            signal.signal(signal.SIGINT, previous)
    try:
        client = Client(cluster)
        try:
            yield client
        finally:
            client.close()
    finally:
        cluster.close()


def _local_cluster(workers: int, LocalCluster: Any) -> Any:
    """Worker processes on 127.0.0.1, one thread each; no dashboard (the scheduler's small HTTP
    endpoint on a free loopback port instead of 8787, which another cluster may hold).

    The workers start without distributed's default ``MALLOC_TRIM_THRESHOLD_=65536``: a fixed
    trim threshold also disables glibc's dynamic mmap threshold (mallopt(3)), leaving it at
    128 KiB, so every large numpy array of a chunk is a fresh mmap with its page faults: a twin
    chunk ran 1.3x slower on such a worker than in this process (2.4x while the analysis still
    computed its uncertainty budget). A value in the environment is still inherited. An
    external cluster (``--scheduler``) keeps its own setting: start its ``dask worker`` with a
    dask config file (e.g. in ``$DASK_CONFIG``) holding ``distributed: nanny:
    pre-spawn-environ: MALLOC_TRIM_THRESHOLD_: null`` for the same speed."""
    import dask

    with dask.config.set({"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None}):
        return LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                            host="127.0.0.1", dashboard_address=None,
                            scheduler_kwargs={"dashboard_address": "127.0.0.1:0"},
                            silence_logs=logging.ERROR)


def run_campaign(task: Task, chunks: Sequence[Any], folder: str | Path, *,
                 scheduler: str | None = None, n_workers: int | None = None, seed: int = 0,
                 identity: dict[str, Any] | None = None, progress: bool = True,
                 client: Any = None, description: str = "chunks",
                 on_chunk: Callable[[int, dict], None] | None = None) -> CampaignResult:
    """Run ``task`` on every chunk spec not finished yet in ``folder``; return all chunks' arrays.

    ``identity`` describes the campaign (it must match on a rerun of the same folder); the task's
    name, the seed and the chunk specs' count are added to it. ``on_chunk(index, arrays)`` is
    called in this process after each chunk is written.
    """
    specs = list(chunks)
    if not specs:
        raise InputError("a campaign needs at least one chunk")
    chunk_seed(seed, 0)  # validates the seed
    ident = {"task": f"{task.__module__}.{getattr(task, '__qualname__', task)}",
             "seed": int(seed), "chunks": len(specs), **(identity or {})}
    store = CampaignStore(folder, ident)
    store.open()
    finished = store.finished(len(specs))
    skipped = sorted(finished)
    pending = [i for i in range(len(specs)) if i not in finished]
    start = time.perf_counter()
    timings: dict[int, float] = {}
    workers = 0  # none ran a chunk (all resumed)
    bar = tqdm(total=len(specs), initial=len(skipped), unit="chunk", desc=description,
               disable=not progress, file=sys.stderr, leave=False)

    def finish(index: int, arrays: dict, seconds: float) -> None:
        store.save(index, arrays)
        timings[index] = seconds
        bar.update(1)
        if on_chunk is not None:
            on_chunk(index, arrays)

    try:
        if pending and scheduler == "inline":
            workers = 1
            for index in pending:
                finish(index, *timed_task(task, specs[index], chunk_seed(seed, index)))
        elif pending:
            with contextlib.ExitStack() as stack:
                if client is None:
                    client = stack.enter_context(dask_client(scheduler, n_workers))
                workers = max(1, len(client.scheduler_info().get("workers", {})))
                _run_on_dask(client, task, specs, pending, seed, finish)
    except KeyboardInterrupt:
        bar.close()
        raise CampaignInterrupted(store.folder, len(store.finished(len(specs))),
                                  len(specs)) from None
    bar.close()
    return CampaignResult(chunks=[store.load(i) for i in range(len(specs))], computed=pending,
                          skipped=skipped, wall_s=time.perf_counter() - start, workers=workers,
                          folder=store.folder, timings_s=timings)


def _run_on_dask(client: Any, task: Task, specs: list, pending: list[int], seed: int,
                 finish: Callable[[int, dict, float], None]) -> None:
    """Submit the pending chunks, write each as it completes; on any exit cancel every future,
    so nothing of the campaign stays on the cluster (even while a traceback holds this frame)."""
    from distributed import as_completed

    futures = {}
    try:
        for index in pending:
            future = client.submit(timed_task, task, specs[index], chunk_seed(seed, index),
                                   pure=False)
            futures[future] = index
        for future in as_completed(list(futures)):
            arrays, seconds = future.result()
            finish(futures[future], arrays, seconds)
    finally:  # pending ones stop; finished ones (already written) release their memory
        if futures:
            client.cancel(list(futures))
        futures.clear()
