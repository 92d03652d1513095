"""Compile the twin's engine into numba's on-disk cache once, at install (``make`` runs it).

A cold start otherwise compiles ``kernel.run_drive`` (and, for ``simulate_batch``, the parallel
``kernel.run_batch``) inside the first run that needs them; with the cache built here a run only
loads them. Run: ``python -m hil.sim.warmup`` — as a command it warms the whole package
(:mod:`hil.warmup`: the engine here, plus the analysis and model kernels a run uses) and prints
what it compiled or loaded and how long; :func:`warm_up` below is the engine's part.
After ``pip install`` (no ``make``), run it once; otherwise the first simulated bench compiles
``run_drive`` when it starts (:func:`prepare_twin_engine`, with a progress line on stderr),
before any instrument is served: a compile inside the first capture held the interpreter long
enough for the drive to lose the master's heartbeat (issue 22.9).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

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


def engine_cached() -> bool | None:
    """Whether numba's on-disk cache holds the twin's ``kernel.run_drive`` (None: unknown, e.g.
    a numba whose cache object no longer says where it keeps its files)."""
    from hil.sim.kernel import run_drive

    if run_drive.signatures:
        return True                       # already compiled or loaded in this process
    cache_dir = getattr(getattr(run_drive, "_cache", None), "_cache_path", None)
    if not cache_dir:
        return None
    return any(Path(cache_dir).glob("kernel.run_drive-*.nbi"))


#: The progress line of a first start that has to compile (stderr).
COMPILING = ("ripple-hil: compiling the simulation engine (once after install: about 45 s on "
             "an idle machine; `python -m hil.sim.warmup` does it ahead) ...")


def prepare_twin_engine(stream=None) -> float:
    """Load the engine a ``DriveTwin`` runs, compiling it (with :data:`COMPILING` and the time
    it took on ``stream``, default stderr) if the on-disk cache does not hold it; returns the
    wall seconds. Call before serving instruments (``SimulatedBench.start``)."""
    from hil.sim.twin import DriveTwin

    stream = sys.stderr if stream is None else stream
    cold = engine_cached() is False
    if cold:
        print(COMPILING, file=stream, flush=True)
    start = time.perf_counter()
    DriveTwin().advance(1e-3, 20_000.0)
    wall_s = time.perf_counter() - start
    if cold:
        print(f"ripple-hil: simulation engine compiled in {wall_s:.0f} s", file=stream,
              flush=True)
    return wall_s


if __name__ == "__main__":
    # the command warms every kernel a run uses; hil.sim itself never imports hil.model
    from hil.warmup import main

    main()
