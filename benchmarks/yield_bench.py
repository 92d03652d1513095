"""Benchmark of yield campaigns: closed-form drives per second; twin drive-seconds per wall second
on 1 and 2 Dask workers with the Dask overhead per task; a projection of a 10⁶-drive twin campaign.

Run: ``.venv/bin/python benchmarks/yield_bench.py [--drives 200000] [--twin-drives 48]
[--full-drives 1000000] [--twin-chunk 4] [--quick]``.

* closed form: ``closed_form_ripple`` on drives sampled from the shipped example tolerances (two
  operating points), one process, best of 3; then the whole ``run_yield`` of the example with
  ``--full-drives`` on a LocalCluster of 2 workers (cluster start-up included and printed).
* twin: the example's drives at its first operating point (500 rpm, 20 A, 2 pole pairs: 10 ms
  settle + 2 electrical revolutions = 0.131 simulated s per drive), chunks of ``--twin-chunk``
  drives (4) on a LocalCluster of 1 and then 2 workers. Drive-seconds = simulated seconds
  summed over drives.
  Then, in this process, where a drive's time goes: simulation, the campaign's analysis (ripple
  figures only) and the full analysis with its uncertainty budget (what campaigns ran before).
* Dask overhead per task: wall × workers − Σ task compute time (measured on the workers),
  divided by the tasks; and the round trip of an empty task.
* projection: T(N) = D·t_drive/N + (D/chunk)·overhead/N — a straight-line extrapolation of the
  one-worker figures, stated as such (no cluster of N workers was run).
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from hil.campaign import chunk_seed, dask_client, run_campaign  # noqa: E402
from hil.campaign.twin import TwinSettings, analyze_drive, simulate_drive  # noqa: E402
from hil.tolerance.engines import (ChunkJob, closed_form_ripple, drive_config,  # noqa: E402
                                   sample_drives, sample_parameters, yield_chunk)
from hil.tolerance.spec import PARAMETERS  # noqa: E402
from hil.tolerance.run import DEFAULT_CHUNK, YieldOptions, run_yield  # noqa: E402
from hil.tolerance.spec import load_tolerances  # noqa: E402

EXAMPLE = ROOT / "hil" / "examples" / "tolerances.toml"


def warm(job) -> None:
    yield_chunk(job, chunk_seed(0, 0))


def empty_task(spec, seed):
    return {"x": np.zeros(1)}


def twin_split(spec, drives: int) -> str:
    """Per drive, in this process (best of 3 passes over ``drives`` drives): simulation, the
    campaign's analysis (no budget) and the full analysis (with the uncertainty budget), ms."""
    settings = TwinSettings()
    op = spec.operating_points[0]
    params = sample_drives(spec, 0, drives)
    configs = [drive_config(op, {name: params[name][i] for name in PARAMETERS})
               for i in range(drives)]
    best = {"simulation": math.inf, "analysis": math.inf, "analysis with budget": math.inf}
    for _ in range(3):
        spent = dict.fromkeys(best, 0.0)
        for config in configs:
            start = time.perf_counter()
            result = simulate_drive(config, settings)
            spent["simulation"] += time.perf_counter() - start
            for label, budget in (("analysis", False), ("analysis with budget", True)):
                start = time.perf_counter()
                analyze_drive(result, config, settings, uncertainty_budget=budget)
                spent[label] += time.perf_counter() - start
        best = {k: min(best[k], spent[k] / drives) for k in best}
    return ", ".join(f"{k} {v * 1e3:.2f} ms" for k, v in best.items())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--drives", type=int, default=200_000)
    parser.add_argument("--full-drives", type=int, default=1_000_000)
    parser.add_argument("--twin-drives", type=int, default=48)
    parser.add_argument("--twin-chunk", type=int, default=4,
                        help="twin drives per Dask task (4: many tasks, the overhead shows)")
    parser.add_argument("--quick", action="store_true", help="small sizes (plumbing check)")
    args = parser.parse_args()
    if args.quick:
        args.drives, args.full_drives, args.twin_drives = 20_000, 50_000, 8
    if not 1 <= args.twin_chunk <= args.twin_drives:
        parser.error(f"--twin-chunk {args.twin_chunk} must be in 1..{args.twin_drives} "
                     "(--twin-drives)")
    spec = load_tolerances(EXAMPLE)
    print(f"cores: {os.cpu_count()}, load average: {os.getloadavg()[0]:.2f}")

    params = sample_parameters(spec, np.random.default_rng(1), args.drives)
    closed_form_ripple(spec.operating_points, {k: v[:1000] for k, v in params.items()}, 1000)
    best = float("inf")
    for _ in range(3):
        start = time.perf_counter()
        closed_form_ripple(spec.operating_points, params, args.drives)
        best = min(best, time.perf_counter() - start)
    print(f"closed form, one core: {args.drives / best:,.0f} drives/s "
          f"({len(spec.operating_points)} operating points, {args.drives:,} drives)")

    with tempfile.TemporaryDirectory() as tmp:
        start = time.perf_counter()
        with dask_client(n_workers=2) as client:
            started = time.perf_counter() - start
            full = dataclasses.replace(spec, drives=args.full_drives)
            run_start = time.perf_counter()
            summary = run_yield(full, Path(tmp) / "full",
                                YieldOptions(progress=False, plots=False), client=client)
            run_s = time.perf_counter() - run_start
        print(f"hil yield closed form, {args.full_drives:,} drives + Sobol' "
              f"({summary['sobol']['evaluations']:,} evaluations), 2 workers: {run_s:.2f} wall s "
              f"(+ {started:.2f} s LocalCluster start); yield {100 * summary['yield']:.2f} %")

    twin_spec = dataclasses.replace(spec, operating_points=spec.operating_points[:1],
                                    drives=args.twin_drives)
    op = twin_spec.operating_points[0]
    per_drive_s = 0.01 + 1.01 * 2 * 60.0 / (op.speed_rpm * op.motor.pole_pairs)
    jobs = [ChunkJob(spec=twin_spec, engine="twin", n=args.twin_chunk,
                     start=i * args.twin_chunk) for i in range(args.twin_drives // args.twin_chunk)]
    twin_drives = len(jobs) * args.twin_chunk  # whole chunks only
    drive_seconds = twin_drives * per_drive_s
    one_worker = {}
    for workers in (1, 2):
        with tempfile.TemporaryDirectory() as tmp, dask_client(n_workers=workers) as client:
            client.run(warm, jobs[0])  # every worker loads the compiled twin before timing
            start = time.perf_counter()
            for i in range(20):
                client.submit(empty_task, None, None, pure=False).result()
            empty_ms = (time.perf_counter() - start) / 20 * 1e3
            result = run_campaign(yield_chunk, jobs, Path(tmp) / "twin", client=client,
                                  progress=False)
            compute_s = sum(result.timings_s.values())
            overhead_ms = max(0.0, result.wall_s * workers - compute_s) / len(jobs) * 1e3
            rate = drive_seconds / result.wall_s
            print(f"twin on {workers} worker(s): {rate:.2f} drive-s per wall s "
                  f"({twin_drives} drives x {per_drive_s:.3f} simulated s in "
                  f"{result.wall_s:.2f} wall s; compute {compute_s / twin_drives * 1e3:.1f} "
                  f"ms per drive on a worker)")
            print(f"dask overhead per task, {workers} worker(s): {overhead_ms:.1f} ms "
                  f"(chunks of {args.twin_chunk} drives); empty-task round trip {empty_ms:.1f} ms")
            if workers == 1:
                one_worker = {"t_drive": compute_s / twin_drives,
                              "overhead": overhead_ms / 1e3}
    print(f"twin per drive in this process ({twin_drives} drives, best of 3): "
          + twin_split(twin_spec, twin_drives))
    drives = 1_000_000
    chunk = DEFAULT_CHUNK["twin"]
    cells = []
    for n in (1, 2, 16, 64, 256):
        seconds = (drives * one_worker["t_drive"] + drives / chunk * one_worker["overhead"]) / n
        cells.append(f"N={n}: {seconds / 3600:.3g} h")
    print(f"projection (extrapolated from 1 worker, not measured): 10^6-drive twin campaign at "
          f"{op.speed_rpm:g} rpm, chunks of {chunk}: " + ", ".join(cells))


if __name__ == "__main__":
    main()
