"""Functional API: simulate one drive configuration, or many in parallel on every core."""

from __future__ import annotations

import threading
from collections.abc import Iterable, Sequence

import numpy as np

from hil.sim import layout as L
from hil.sim.config import DriveConfig
from hil.sim.kernel import run_batch, run_drive
from hil.sim.packing import new_state, pack_params
from hil.sim.results import (SimResult, name_channels, result_meta, select_channels,
                             transducer_gain_error)

#: numba's default (workqueue) threading layer must not run two parallel kernels at once
_PARALLEL_LOCK = threading.Lock()


def sample_count(duration_s: float, sample_rate_hz: float) -> int:
    """Samples at t0 + j/fs for j = 0 .. n-1 covering [t0, t0 + duration)."""
    if not duration_s >= 0 or not sample_rate_hz > 0:
        raise ValueError(f"duration_s must be >= 0 and sample_rate_hz > 0, got {duration_s!r}, "
                         f"{sample_rate_hz!r}")
    return int(np.floor(duration_s * sample_rate_hz + 1e-9))


def simulate(config: DriveConfig, duration_s: float, sample_rate_hz: float, *, seed: int = 0,
             settle_s: float = 0.0, channels: Iterable[str] | None = None) -> SimResult:
    """Run ``config`` from rest; record ``duration_s`` at ``sample_rate_hz`` after ``settle_s``.

    ``time_s`` counts from the start of the run, so the first sample is at ``settle_s``.
    ``channels``: None for every standard channel, else only those named are computed and
    returned (``results.STANDARD_CHANNELS``; an unknown name is a ValueError).
    """
    return simulate_batch([config], duration_s, sample_rate_hz, seed=seed, settle_s=settle_s,
                          parallel=False, channels=channels)[0]


def simulate_batch(configs: Sequence[DriveConfig], duration_s: float, sample_rate_hz: float, *,
                   seed: int = 0, settle_s: float = 0.0, parallel: bool = True,
                   channels: Iterable[str] | None = None) -> list[SimResult]:
    """Simulate many configurations in one call, in parallel over all cores (numba prange).

    Configuration b gets the transducer randomness of ``SeedSequence(seed).spawn(...)[b]``; the
    drive itself is deterministic. ``channels`` as in ``simulate`` (the same for every one).
    """
    n = sample_count(duration_s, sample_rate_hz)
    if not settle_s >= 0:
        raise ValueError(f"settle_s must be >= 0, got {settle_s!r}")
    names, rows = select_channels(channels)
    params = np.stack([pack_params(c) for c in configs]) if configs else np.zeros((0, L.N_PARAMS))
    states = np.stack([new_state() for _ in configs]) if configs else np.zeros((0, L.N_STATE))
    outs = np.zeros((len(configs), int((rows >= 0).sum()), n))
    latest = np.zeros((len(configs), L.N_CHANNELS))
    end_s = settle_s + duration_s
    if parallel and len(configs) > 1:
        with _PARALLEL_LOCK:
            run_batch(params, states, settle_s, 1.0 / sample_rate_hz, outs, rows, latest, end_s)
    else:
        for b in range(len(configs)):
            run_drive(params[b], states[b], settle_s, 1.0 / sample_rate_hz, outs[b], rows,
                      latest[b], end_s)
    results = []
    children = np.random.SeedSequence(seed).spawn(len(configs))
    for config, out, child in zip(configs, outs, children):
        rng = np.random.default_rng(child)
        gain_error = transducer_gain_error(config, rng)
        results.append(SimResult(channels=name_channels(out, rows, names, config, gain_error,
                                                        rng),
                                 meta=result_meta(config, sample_rate_hz, seed, gain_error)))
    return results
