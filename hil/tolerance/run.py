"""``run_yield``: Monte Carlo yield, ripple distribution and Sobol' ranking of a tolerance spec.

Folder layout: ``monte_carlo/`` and ``sobol/`` are campaign folders (resumable chunk files);
``yield.json``, ``histogram.png`` and ``histogram.svg`` are written at the end. A drive passes
when its pk-pk ripple meets the limit at every operating point; the yield is the passing
fraction with its 95 % Clopper–Pearson interval, and a ripple quantile is stated only where the
sample supports it (``hil.tolerance.stats``): statements about the Monte Carlo sample, not about
the model's own accuracy.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import math
import time
from pathlib import Path
from typing import Any

import numpy as np

from hil.campaign import chunk_sizes, dask_client, run_campaign
from hil.campaign.store import write_atomic
from hil.campaign.twin import TwinSettings
from hil.tolerance.combiner import CombinerSettings
from hil.tolerance.engines import ChunkJob, parameters_from_unit, yield_chunk
from hil.tolerance.sobol import run_sobol
from hil.tolerance.spec import PARAMETERS, ToleranceSpec
from hil.tolerance.stats import CI_METHOD, QUANTILE_RULE, histogram, quantiles, yield_interval

#: Drives per chunk: a twin drive takes ~3 ms per operating point on one core and a Dask task
#: ~10 ms of overhead (benchmarks/yield_bench.py), so 64 drives keep the overhead near 5 %.
DEFAULT_CHUNK = {"closed-form": 50_000, "twin": 64}


@dataclasses.dataclass(frozen=True)
class YieldOptions:
    engine: str = "closed-form"
    scheduler: str | None = None
    n_workers: int | None = None
    chunk_size: int | None = None
    sobol_n: int = 1024
    combiner: CombinerSettings = CombinerSettings()
    twin: TwinSettings = TwinSettings()
    progress: bool = True
    plots: bool = True


def run_yield(spec: ToleranceSpec, folder: str | Path, options: YieldOptions = YieldOptions(),
              *, client: Any = None) -> dict:
    """Run the Monte Carlo and Sobol' campaigns of ``spec`` (which must have a requirement)."""
    folder = Path(folder)
    spec = spec.with_requirement()
    start = time.perf_counter()
    with contextlib.ExitStack() as stack:
        if client is None and options.scheduler != "inline":
            client = stack.enter_context(dask_client(options.scheduler, options.n_workers))
        mc = monte_carlo(spec, folder / "monte_carlo", options, client)
        sobol = sensitivity(spec, folder / "sobol", options, client) \
            if spec.varied and options.sobol_n else None
    summary = summarise(spec, mc, options)
    summary["sobol"] = sobol
    summary["campaign"] = {"folder": str(folder), "scheduler": options.scheduler or "LocalCluster",
                           "workers": mc.workers, "chunks": len(mc.chunks),
                           "chunks_computed": len(mc.computed), "chunks_resumed": len(mc.skipped),
                           "wall_s": time.perf_counter() - start}
    folder.mkdir(parents=True, exist_ok=True)
    if options.plots:
        from hil.tolerance.plots import plot_histogram
        summary["figures"] = plot_histogram(mc.concatenated("ripple_pu"), spec, folder,
                                            summary)
    write_atomic(folder / "yield.json", json.dumps(summary, indent=2).encode())
    return summary


def _job(spec: ToleranceSpec, options: YieldOptions, **kw: Any) -> ChunkJob:
    return ChunkJob(spec=spec, engine=options.engine, combiner=options.combiner,
                    twin=options.twin, **kw)


def _identity(spec: ToleranceSpec, options: YieldOptions, **extra: Any) -> dict:
    return {"spec": spec.to_dict(), "engine": options.engine,
            "combiner": dataclasses.asdict(options.combiner),
            "twin": dataclasses.asdict(options.twin), **extra}


def monte_carlo(spec: ToleranceSpec, folder: Path, options: YieldOptions, client: Any):
    size = options.chunk_size or DEFAULT_CHUNK[options.engine]
    sizes = chunk_sizes(spec.drives, size)
    starts = np.cumsum([0] + sizes[:-1])
    jobs = [_job(spec, options, n=n, start=int(s)) for n, s in zip(sizes, starts)]
    return run_campaign(yield_chunk, jobs, folder, scheduler=options.scheduler,
                        n_workers=options.n_workers, seed=spec.seed, client=client,
                        progress=options.progress, description=f"{options.engine} drives",
                        identity=_identity(spec, options, chunk_size=size))


def sensitivity(spec: ToleranceSpec, folder: Path, options: YieldOptions, client: Any) -> dict:
    """Sobol' indices of the varied tolerances, evaluated by the chosen engine in chunks."""
    names = spec.varied
    size = options.chunk_size or DEFAULT_CHUNK[options.engine]

    def evaluate(unit: dict[str, np.ndarray]) -> np.ndarray:
        n = len(next(iter(unit.values())))
        rows = parameters_from_unit(spec, unit, n)
        jobs = [_job(spec, options, rows={k: v[i:i + size] for k, v in rows.items()})
                for i in range(0, n, size)]
        result = run_campaign(yield_chunk, jobs, folder, scheduler=options.scheduler,
                              n_workers=options.n_workers, seed=spec.seed, client=client,
                              progress=options.progress, description="Sobol' samples",
                              identity=_identity(spec, options, sobol_n=options.sobol_n,
                                                 chunk_size=size))
        return 100.0 * spec.worst_pu(result.concatenated("ripple_pu"))

    return run_sobol(names, options.sobol_n, spec.seed, evaluate, spec.requirement.limit_pct)


def summarise(spec: ToleranceSpec, mc, options: YieldOptions) -> dict:
    """Yield ± CI, quantiles and histogram of the worst-point ripple, per-point figures."""
    ripple_pct = 100.0 * mc.concatenated("ripple_pu")
    limit = spec.requirement.limit_pct
    worst = spec.worst_pu(ripple_pct)
    passed = int(np.count_nonzero(worst <= limit))
    total = int(worst.size)
    low, high = yield_interval(passed, total)
    per_point = []
    for j, op in enumerate(spec.operating_points):
        ok = int(np.count_nonzero(ripple_pct[:, j] <= limit))
        judged = j in spec.judged
        per_point.append({"speed_rpm": op.speed_rpm, "current_a": op.current_a,
                          "current_angle_deg": math.degrees(op.current_angle_rad),
                          "judged": judged, "yield": ok / total if judged else None,
                          "yield_ci95": list(yield_interval(ok, total)) if judged else None,
                          "ripple_pct_quantiles": quantiles(ripple_pct[:, j])})
    clipped = {}
    for name in spec.varied:
        values = mc.concatenated(f"param:{name}")
        info = PARAMETERS[name]
        clipped[name] = float(np.mean((values <= info.low) | (values >= info.high)))
    return {
        "engine": options.engine, "spec": spec.to_dict(),
        "requirement": spec.requirement.to_dict(), "drives": total, "passed": passed,
        "yield": passed / total, "yield_ci95": [low, high],
        "ci_method": CI_METHOD, "quantile_rule": QUANTILE_RULE,
        "pass_rule": "pk-pk ripple <= limit at every operating point the requirement applies to",
        "ripple_definition": ("pk-pk of the air-gap torque over one electrical revolution, "
                              f"electrical orders 1..{options.combiner.max_order if options.engine == 'closed-form' else options.twin.max_order}, "
                              "% of its mean torque; worst over the operating points"),
        "bounds_added": options.combiner.bounds if options.engine == "closed-form" else None,
        "worst_ripple_pct_quantiles": quantiles(worst),
        "worst_ripple_pct_mean": float(worst.mean()),
        "worst_ripple_pct_histogram": histogram(worst),
        "per_point": per_point, "clipped_fraction": clipped,
    }
