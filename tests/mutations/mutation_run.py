"""Run test plans against a simulated drive with test-only defects and tell which plans failed.

The defects are those of :class:`hil.sim.defects.DriveDefects`, given to the plans as the
ripple-hil plugin's ``--hil-sim-defect KEY=VALUE`` options; the plans run in a separate pytest
process over the real stacks (CANopen, Modbus TCP, serial pty), exactly as ``hil run`` runs them.
"""

from __future__ import annotations

import os
import subprocess
import sys
from collections import Counter, defaultdict
from pathlib import Path

import ripple_hil_testplans
from hil.record import load_record

PLANS = Path(ripple_hil_testplans.__file__).parent
FAILED = ("failed", "error")


def run_plans(sources, defects: dict, folder: Path, *, timeout_s: float = 600.0,
              select: str | None = None, bench: Path | None = None,
              model_scale: dict | None = None) -> dict:
    """Run the plans of ``sources`` with ``defects``; per source, a Counter of test outcomes.

    ``select``: a pytest ``-k`` expression (a few points of each plan, to keep a case fast);
    ``bench``: a bench file other than the default simulated bench; ``model_scale``:
    {source: factor}, a closed-form model made that many times too large (``model_mutation``)."""
    folder.mkdir(parents=True, exist_ok=True)
    args = [sys.executable, "-m", "pytest", *[str(PLANS / f"test_{s}.py") for s in sources],
            "-q", "-p", "no:cacheprovider", "--hil-record", str(folder / "records")]
    if select:
        args += ["-k", select]
    if bench is not None:
        args += ["--hil-bench", str(bench)]
    for source, factor in (model_scale or {}).items():
        args += ["-p", "model_mutation", "--mutate-model", f"{source}={factor}"]
    for key, value in defects.items():
        text = str(value).lower() if isinstance(value, bool) else value   # a TOML value
        args += ["--hil-sim-defect", f"{key}={text}"]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [str(Path(__file__).parent), *filter(None, [os.environ.get("PYTHONPATH")])]))
    done = subprocess.run(args, capture_output=True, text=True, timeout=timeout_s, cwd=folder,
                          env=env)
    # record folders only (the results database may sit beside them)
    records = sorted(p for p in (folder / "records").iterdir() if p.is_dir()) \
        if (folder / "records").exists() else []
    outcomes: dict[str, Counter] = defaultdict(Counter)
    if records:
        record = load_record(records[-1])
        for test in record["tests"]:
            outcomes[test.get("source") or "?"][test.get("outcome")] += 1
        if "failed" in (record.get("characterisation") or {}):
            # the run stopped at the characterisation stage (no plan ran): the stage caught it
            outcomes["characterisation"]["error"] += 1
    return {"returncode": done.returncode, "outcomes": dict(outcomes),
            "output": done.stdout[-4000:] + done.stderr[-2000:]}


def refused_sources(run: dict) -> set[str]:
    """Sources none of whose tests was judged: every one not determinable (refused, with the
    reason in the record) or not run."""
    return {source for source, counts in run["outcomes"].items()
            if counts and not any(counts[o] for o in (*FAILED, "passed"))}


def failed_sources(run: dict, outcomes=FAILED) -> set[str]:
    """Sources with at least one test of ``outcomes`` (default: failed or errored) in the
    record; ``outcomes=("failed",)``: a verdict that failed, not a plan that broke."""
    return {source for source, counts in run["outcomes"].items()
            if any(counts[o] for o in outcomes)}
