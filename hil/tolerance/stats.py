"""Yield statistics: Wilson score interval, quantiles, histogram counts."""

from __future__ import annotations

import math

import numpy as np
from scipy.stats import norm

from hil.errors import InputError


def wilson_interval(passed: int, total: int, confidence: float = 0.95) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion (Wilson 1927; Agresti & Coull 1998).

    p̂ = passed/total, z the two-sided normal quantile: (p̂ + z²/2n ± z·sqrt(p̂(1−p̂)/n +
    z²/4n²)) / (1 + z²/n). Unlike the normal approximation it stays inside [0, 1] and is not
    degenerate at 0 or n successes.
    """
    if not 0 <= passed <= total or total < 1:
        raise InputError(f"need 0 <= passed <= total and total >= 1, got {passed}/{total}")
    if not 0 < confidence < 1:
        raise InputError(f"confidence={confidence!r} must be in (0, 1)")
    z = float(norm.ppf(0.5 + confidence / 2.0))
    p = passed / total
    denominator = 1.0 + z * z / total
    centre = (p + z * z / (2 * total)) / denominator
    half = z * math.sqrt(p * (1 - p) / total + z * z / (4 * total * total)) / denominator
    return max(0.0, centre - half), min(1.0, centre + half)


QUANTILES = (0.5, 0.9, 0.95, 0.99, 0.999)


def quantiles(values: np.ndarray, probabilities=QUANTILES) -> dict[str, float]:
    return {f"q{100 * p:g}": float(np.quantile(values, p)) for p in probabilities}


def histogram(values: np.ndarray, bins: int = 80) -> dict[str, list]:
    counts, edges = np.histogram(values, bins=bins)
    return {"counts": counts.tolist(), "edges": edges.tolist()}
