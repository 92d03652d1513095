"""One grid run on a worker: the normal ``hil run`` in its own process, its record as bytes.

The worker writes the run's bench file into a temporary folder, runs ``python -m hil run
--bench FILE --no-report --results-db off`` there (its own simulated bench: instruments on free
loopback ports, its own CAN bus and pty), and returns the sealed record folder as a tar archive,
so the client needs no shared file system with the workers. The child is tied to the worker:
on Linux it gets SIGKILL when the worker process dies (``PR_SET_PDEATHSIG``), so a killed worker
leaves no orphan run behind; Dask then runs the task again on another worker.
"""

from __future__ import annotations

import io
import os
import signal
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path

import tomli_w

from hil.campaign.grid_spec import GridRun

#: Characters of the run's output kept for a run that left no record.
OUTPUT_TAIL = 3000


def _die_with_parent() -> None:  # pragma: no cover - runs in the child before exec
    """Ask Linux to SIGKILL this child when the worker that started it dies."""
    try:
        import ctypes

        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass


def execute_run(run: GridRun) -> dict:
    """Run ``run``; its exit status, wall time, worker, and the record folder as tar bytes
    (``record_tar``: None when the run left no record — then ``output`` says why)."""
    started = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="hil-grid-") as tmp:
        folder = Path(tmp)
        bench = folder / "bench.toml"
        bench.write_text(tomli_w.dumps(run.bench))
        records = folder / "records"
        args = [sys.executable, "-m", "hil", "run", "--bench", str(bench), "--no-report",
                "--record-dir", str(records), "--results-db", "off", "--seed", str(run.seed)]
        for source in run.sources:
            args += ["--source", source]
        env = os.environ | {"RIPPLE_HIL_RESULTS_DB": "off"}
        try:
            done = subprocess.run(args, capture_output=True, text=True, cwd=folder, env=env,
                                  timeout=run.timeout_s,
                                  preexec_fn=_die_with_parent if sys.platform == "linux"
                                  else None)
            status, output = done.returncode, done.stdout + done.stderr
        except subprocess.TimeoutExpired as exc:
            status = None
            output = f"timed out after {run.timeout_s:g} s\n" + "".join(
                part.decode(errors="replace") if isinstance(part, bytes) else part or ""
                for part in (exc.stdout, exc.stderr))
        found = sorted(p for p in records.iterdir() if p.is_dir()) if records.exists() else []
        archive = None
        if found:
            buffer = io.BytesIO()
            with tarfile.open(fileobj=buffer, mode="w") as tar:
                tar.add(found[-1], arcname="record")
            archive = buffer.getvalue()
    return {"key": run.key, "exit_status": status, "seconds": time.perf_counter() - started,
            "worker_pid": os.getpid(), "record_tar": archive,
            "output": None if archive else output[-OUTPUT_TAIL:]}
