"""Chunk plans and deterministic per-chunk seeds (design.md §8).

A campaign of ``total`` items is cut into chunks of at most ``chunk_size``; chunk ``i`` draws its
random numbers from ``SeedSequence(seed, spawn_key=(i,))`` — the i-th child that
``SeedSequence(seed).spawn(...)`` would give — so its numbers depend on the campaign seed and the
chunk index only, never on how many workers ran the campaign or in which order chunks finished.
"""

from __future__ import annotations

import numpy as np

from hil.errors import InputError


def chunk_seed(seed: int, index: int) -> np.random.SeedSequence:
    """The seed sequence of chunk ``index`` of a campaign seeded with ``seed``."""
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise InputError(f"seed={seed!r} must be an integer >= 0")
    return np.random.SeedSequence(int(seed), spawn_key=(int(index),))


def chunk_sizes(total: int, chunk_size: int) -> list[int]:
    """Sizes of the chunks of ``total`` items, each at most ``chunk_size`` (the last one smaller)."""
    if isinstance(total, bool) or not isinstance(total, (int, np.integer)) or total < 1:
        raise InputError(f"the campaign size {total!r} must be an integer >= 1")
    if isinstance(chunk_size, bool) or not isinstance(chunk_size, (int, np.integer)) \
            or chunk_size < 1:
        raise InputError(f"chunk_size={chunk_size!r} must be an integer >= 1")
    full, rest = divmod(int(total), int(chunk_size))
    return [int(chunk_size)] * full + ([rest] if rest else [])
