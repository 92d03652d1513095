"""Yield statistics that state only what the Monte Carlo sample supports.

* Yield: the passing fraction with its Clopper–Pearson ("exact") binomial interval — the one
  interval of every yield this package prints or writes (``CI_METHOD``). Its coverage is at
  least the confidence for every sample size and true yield, also when every drive of a small
  sample passes (8 of 8: 63.1 % .. 100 %), where the Wilson interval's coverage falls below it.
* Quantiles of the ripple: the sample quantile q is stated only when at least
  ``TAIL_DRIVES`` = k drives are expected beyond it, n ≥ k / min(q, 1 − q) (``QUANTILE_RULE``);
  otherwise it is "not stated" with the drives it needs (q99.9 needs 10,000). A stated
  quantile carries its distribution-free 95 % interval from order statistics (David &
  Nagaraja, Order Statistics, 3rd ed. 2003): [x₍ₗ₎, x₍ᵤ₎] with l, u from the Binomial(n, q)
  quantiles, coverage ≥ 95 % for any continuous distribution (k = 10 keeps both ends inside
  the sample).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.stats import beta, binom

from hil.errors import InputError

CONFIDENCE = 0.95
CI_NAME = "Clopper-Pearson"
CI_METHOD = f"{CI_NAME} (exact binomial), 95 %"
QUANTILES = (0.5, 0.9, 0.95, 0.99, 0.999)
#: k: drives expected beyond a quantile before it is stated (module docstring).
TAIL_DRIVES = 10
QUANTILE_RULE = (f"a quantile q is stated when drives >= {TAIL_DRIVES}/min(q, 1-q) (at least "
                 f"{TAIL_DRIVES} drives expected beyond it); its 95 % interval is "
                 "distribution-free, from order statistics")


def yield_interval(passed: int, total: int, confidence: float = CONFIDENCE
                   ) -> tuple[float, float]:
    """Clopper–Pearson interval of a binomial proportion (Clopper & Pearson 1934): the p whose
    binomial tails at the observed count are (1 − confidence)/2 each, via the Beta quantiles
    B(α/2; x, n − x + 1) and B(1 − α/2; x + 1, n − x); 0 and 1 at x = 0 and x = n."""
    if isinstance(passed, bool) or isinstance(total, bool) or not 0 <= passed <= total \
            or total < 1:
        raise InputError(f"need 0 <= passed <= total and total >= 1, got {passed}/{total}")
    if not 0 < confidence < 1:
        raise InputError(f"confidence={confidence!r} must be in (0, 1)")
    alpha = 1.0 - confidence
    low = 0.0 if passed == 0 else float(beta.ppf(alpha / 2, passed, total - passed + 1))
    high = 1.0 if passed == total else float(beta.ppf(1 - alpha / 2, passed + 1, total - passed))
    return low, high


def drives_needed(probability: float, tail_drives: int = TAIL_DRIVES) -> int:
    """Smallest sample for which the quantile ``probability`` is stated (module docstring)."""
    if not 0.0 < probability < 1.0:
        raise InputError(f"quantile probability {probability!r} must be in (0, 1)")
    return math.ceil(tail_drives / min(probability, 1.0 - probability) - 1e-9)


def quantile_label(probability: float) -> str:
    return f"q{100 * probability:g}"


def quantiles(values: np.ndarray, probabilities=QUANTILES) -> dict[str, dict]:
    """Per quantile: ``{"value", "ci95"}`` when the sample supports it, else
    ``{"value": None, "needs_drives": N}`` (module docstring)."""
    ordered = np.sort(np.asarray(values, dtype=float))
    n = ordered.size
    table = {}
    for p in probabilities:
        needed = drives_needed(p)
        if n < needed:
            table[quantile_label(p)] = {"value": None, "needs_drives": needed}
            continue
        table[quantile_label(p)] = {"value": float(np.quantile(ordered, p)),
                                    "ci95": order_statistic_interval(ordered, p)}
    return table


def order_statistic_interval(ordered: np.ndarray, probability: float,
                             confidence: float = CONFIDENCE) -> list[float] | None:
    """[x₍ₗ₎, x₍ᵤ₎] covering the ``probability`` quantile with ≥ ``confidence``: with K ~
    Binomial(n, q) drives below it, l = the α/2 quantile of K and u = its 1 − α/2 quantile + 1
    (1-based), so P(x₍ₗ₎ ≤ ξ_q < x₍ᵤ₎) = F(u − 1) − F(l − 1) ≥ 1 − α. None if either order
    statistic falls outside the sample."""
    n = ordered.size
    alpha = 1.0 - confidence
    low = int(binom.ppf(alpha / 2, n, probability))
    high = int(binom.ppf(1 - alpha / 2, n, probability)) + 1
    if low < 1 or high > n:
        return None
    return [float(ordered[low - 1]), float(ordered[high - 1])]


def percent_decimals(drives: int) -> int:
    """Decimals of a percentage that ``drives`` resolve (1/drives): none for 8 drives, two for
    2,000, at most three."""
    return min(3, max(0, math.ceil(math.log10(drives)) - 2))


def format_percent(value: float, drives: int, rounding=round) -> str:
    """A fraction in % at ``percent_decimals``: to nearest, where a fraction strictly between
    0 and 1 is never printed as 0 or 100; or by ``rounding`` (math.floor for a lower
    confidence bound, math.ceil for an upper one, so that a printed interval contains the
    computed one)."""
    decimals = percent_decimals(drives)
    scaled = round(100 * value * 10 ** decimals, 9)      # 62.99999... is 63 before a floor
    steps = rounding(scaled)
    if rounding is round and 0.0 < value < 1.0:
        steps = min(max(steps, 1), 100 * 10 ** decimals - 1)
    return f"{steps / 10 ** decimals:.{decimals}f}"


def format_yield(value: float, ci, drives: int) -> str:
    """``87 % (95 % CI 47 .. 100 %)``: the yield to nearest, its interval rounded outwards."""
    low = format_percent(ci[0], drives, math.floor)
    high = format_percent(ci[1], drives, math.ceil)
    return f"{format_percent(value, drives)} % (95 % CI {low} .. {high} %)"


def histogram(values: np.ndarray, bins: int = 80) -> dict[str, list]:
    counts, edges = np.histogram(values, bins=bins)
    return {"counts": counts.tolist(), "edges": edges.tolist()}
