"""Histogram of the worst-point pk-pk ripple with the limit, as PNG and SVG (matplotlib, Agg)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from hil.tolerance.spec import ToleranceSpec
from hil.tolerance.stats import CI_NAME, format_yield


def plot_histogram(ripple_pu: np.ndarray, spec: ToleranceSpec, folder: Path,
                   summary: dict) -> dict[str, str]:
    """Write ``histogram.png`` and ``histogram.svg`` in ``folder``; return their paths. The
    title states the yield and its interval as ``summary`` (``run.summarise``) does."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    worst = 100.0 * spec.worst_pu(ripple_pu)
    limit = spec.requirement.limit_pct
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.hist(worst, bins=80, color="#4477aa")
    ax.axvline(limit, color="#cc3311", linestyle="--", label=f"limit {limit:g} %")
    ax.set_xlabel("pk-pk torque ripple, % of the mean torque (worst judged operating point)")
    ax.set_ylabel("drives")
    low, high = summary["yield_ci95"]
    text = format_yield(summary["yield"], (low, high), worst.size)
    ax.set_title(f"{worst.size:,} drives: yield {text[:-1]}, {CI_NAME})", fontsize=10)
    ax.legend()
    fig.tight_layout()
    paths = {}
    for ext in ("png", "svg"):
        path = folder / f"histogram.{ext}"
        fig.savefig(path, dpi=120)
        paths[ext] = str(path)
    plt.close(fig)
    return paths
