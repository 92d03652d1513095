"""Per-parameter tolerance distributions: normal (σ), uniform (±), fixed, discrete choice.

Every distribution draws from a numpy Generator (Monte Carlo) and maps a uniform u ∈ [0, 1)
through its inverse CDF (``ppf``: Sobol' sampling, common random numbers of the inverse design).
``spread`` is the tolerance (σ or the ± half width; 0 for fixed and choice) and ``scaled(k)``
the same distribution with its spread multiplied by k (the inverse design's variable). Normal
draws are clipped to the parameter's allowed range (the knob's range), so a wide σ never asks
the drive for an impossible value; the clipped fraction is part of the result.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy.special import ndtri

from hil.errors import InputError


@dataclass(frozen=True)
class Normal:
    mean: float
    sigma: float
    low: float
    high: float

    kind = "normal"

    @property
    def spread(self) -> float:
        return self.sigma

    def scaled(self, factor: float) -> "Normal":
        return replace(self, sigma=self.sigma * factor)

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        return np.clip(rng.normal(self.mean, self.sigma, n), self.low, self.high)

    def ppf(self, u: np.ndarray) -> np.ndarray:
        z = ndtri(np.clip(u, 1e-12, 1 - 1e-12))
        return np.clip(self.mean + self.sigma * z, self.low, self.high)

    def describe(self) -> dict:
        return {"distribution": "normal", "mean": self.mean, "sigma": self.sigma,
                "clipped_to": [self.low, self.high]}


@dataclass(frozen=True)
class Uniform:
    mean: float
    half_width: float
    low: float
    high: float

    kind = "uniform"

    @property
    def spread(self) -> float:
        return self.half_width

    def scaled(self, factor: float) -> "Uniform":
        return replace(self, half_width=self.half_width * factor)

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        return self.ppf(rng.random(n))

    def ppf(self, u: np.ndarray) -> np.ndarray:
        return np.clip(self.mean + self.half_width * (2.0 * np.asarray(u) - 1.0),
                       self.low, self.high)

    def describe(self) -> dict:
        return {"distribution": "uniform", "mean": self.mean, "half_width": self.half_width}


@dataclass(frozen=True)
class Fixed:
    value: float

    kind = "fixed"
    spread = 0.0

    def scaled(self, factor: float) -> "Fixed":
        return self

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        return np.full(n, float(self.value))

    def ppf(self, u: np.ndarray) -> np.ndarray:
        return np.full(np.shape(u), float(self.value))

    def describe(self) -> dict:
        return {"distribution": "fixed", "value": self.value}


#: How far the weights of a choice may sum from 1 (rounding of decimal weights, e.g. 3 × 1/3).
WEIGHT_SUM_TOLERANCE = 1e-9


@dataclass(frozen=True)
class Choice:
    """Discrete values with probabilities ``weights`` (each >= 0, summing to 1 within
    ``WEIGHT_SUM_TOLERANCE``: weights that do not are refused, never silently normalised)."""

    values: tuple[float, ...]
    weights: tuple[float, ...]

    kind = "choice"
    spread = 0.0

    def __post_init__(self) -> None:
        if len(self.weights) != len(self.values) or not self.values:
            raise InputError(f"choice: {len(self.values)} values and {len(self.weights)} "
                             "weights (need as many, at least one)")
        if not all(0.0 <= w < math.inf for w in self.weights):
            raise InputError(f"choice weights {list(self.weights)} must each be >= 0")
        total = math.fsum(self.weights)
        if abs(total - 1.0) > WEIGHT_SUM_TOLERANCE:
            raise InputError(f"choice weights sum to {total:.12g}, not 1 (|sum - 1| must be "
                             f"<= {WEIGHT_SUM_TOLERANCE:g}; they are probabilities, not ratios)")

    def scaled(self, factor: float) -> "Choice":
        return self

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        return self.ppf(rng.random(n))

    def ppf(self, u: np.ndarray) -> np.ndarray:
        edges = np.cumsum(self.weights) / math.fsum(self.weights)  # the last edge exactly 1
        index = np.minimum(np.searchsorted(edges, np.asarray(u), side="right"),
                           len(self.values) - 1)
        return np.asarray(self.values, dtype=float)[index]

    def describe(self) -> dict:
        return {"distribution": "choice", "values": list(self.values),
                "weights": list(self.weights)}


Distribution = Normal | Uniform | Fixed | Choice
