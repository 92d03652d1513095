"""Compile the twin's engine into numba's on-disk cache once, at install (``make`` runs it).

A cold start otherwise compiles ``kernel.run_drive`` (and, for ``simulate_batch``, the parallel
``kernel.run_batch``) inside the first run that needs them; with the cache built here a run only
loads them. Run: ``python -m hil.sim.warmup`` (prints what it compiled or loaded and how long).
"""

from __future__ import annotations

import time

from hil.sim.config import DriveConfig
from hil.sim.engine import simulate, simulate_batch


def warm_up() -> dict[str, float]:
    """Wall seconds to compile (or load from the cache) each engine entry point."""
    seconds = {}
    start = time.perf_counter()
    simulate(DriveConfig(), 1e-3, 20_000.0)
    seconds["run_drive"] = time.perf_counter() - start
    start = time.perf_counter()
    simulate_batch([DriveConfig(), DriveConfig()], 1e-3, 20_000.0)
    seconds["run_batch"] = time.perf_counter() - start
    return seconds


if __name__ == "__main__":
    for name, wall_s in warm_up().items():
        print(f"hil.sim engine {name}: compiled or loaded in {wall_s:.1f} s")
