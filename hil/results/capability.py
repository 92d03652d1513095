"""Process capability and control limits of a measured quantity over runs or units.

* Individuals control chart (Shewhart X chart with the moving range; Montgomery, *Introduction
  to Statistical Quality Control*, §6.4): centre line x̄, σ̂ = MR̄/d₂ with d₂ = 1.128 for moving
  ranges of two, limits x̄ ± 3σ̂; a point beyond them is flagged (rule 1 only).
* Cp = (USL − LSL)/(6s) and Cpk = min(USL − x̄, x̄ − LSL)/(3s) from the overall sample standard
  deviation s (n − 1); one-sided limits give Cpk only (Cpu or Cpl). 95 % intervals: for Cp the
  exact χ² interval Cp·√(χ²_{α/2, n−1}/(n−1)) … Cp·√(χ²_{1−α/2, n−1}/(n−1)); for Cpk Bissell's
  normal approximation (A. F. Bissell, "How reliable is your capability index?", Appl. Statist.
  39(3), 1990): Cpk ± z_{1−α/2}·√(1/(9n) + Cpk²/(2(n − 1))). Both assume a stable, normal
  process: the control chart is printed beside them to show whether it is.
* When n is too small to state them (issue 32 item 5): control limits need at least
  :data:`MIN_CONTROL_N` values (Montgomery §6.4: trial limits from 20–25 observations; fewer give
  a σ̂ from too few moving ranges), Cp/Cpk at least :data:`MIN_CAPABILITY_N` (this project's
  choice: below it Bissell's 95 % half-width exceeds ±0.65 at Cpk 1.33, and its normal
  approximation is poorest). Below, the values are computed (JSON) but flagged ``stated: false``
  with the reason, and the commands print the reason instead of the numbers. A 3σ̂ lower limit
  below zero for a quantity that cannot be negative (a pk-pk, a % of the mean torque) is not a
  limit: it is dropped, with a note saying why.
* Measured yield: the share of runs accepted, with the Clopper–Pearson interval
  (``hil.tolerance.stats.yield_interval``).
"""

from __future__ import annotations

import math

import numpy as np

CONFIDENCE = 0.95
D2_MOVING_RANGE_2 = 1.128
MIN_CONTROL_N = 20
MIN_CAPABILITY_N = 10


def control_chart(values: list[float], nonnegative: bool = False) -> dict:
    """Centre line, σ̂ from the moving range, 3σ̂ limits and the indices beyond them; whether
    n allows stating the limits, and a note when a lower limit below 0 was dropped."""
    x = np.asarray(values, dtype=float)
    centre = float(np.mean(x))
    stated = len(x) >= MIN_CONTROL_N
    reason = None if stated else (f"{len(x)} value(s) are too few to state control limits "
                                  f"(at least {MIN_CONTROL_N})")
    if len(x) < 2:
        return {"centre": centre, "sigma_short": None, "ucl": None, "lcl": None,
                "beyond": [], "stated": False, "reason": reason, "lcl_note": None}
    sigma = float(np.mean(np.abs(np.diff(x)))) / D2_MOVING_RANGE_2
    ucl, lcl = centre + 3 * sigma, centre - 3 * sigma
    note = None
    if nonnegative and lcl < 0:
        note = (f"the 3σ̂ lower limit {lcl:.4g} is below 0, which this quantity cannot reach: "
                f"no lower limit (the values are not normal near 0)")
        lcl = None
    beyond = [int(i) for i in np.flatnonzero((x > ucl) | ((x < lcl) if lcl is not None
                                                          else False))]
    return {"centre": centre, "sigma_short": sigma, "ucl": ucl, "lcl": lcl, "beyond": beyond,
            "stated": stated, "reason": reason, "lcl_note": note}


def capability(values: list[float], lower: float | None, upper: float | None,
               confidence: float = CONFIDENCE) -> dict:
    """Cp and Cpk with their intervals (None where the limits or n < 2 do not allow them)."""
    from scipy.stats import chi2, norm

    x = np.asarray(values, dtype=float)
    n = len(x)
    stated = n >= MIN_CAPABILITY_N
    out = {"n": n, "mean": float(np.mean(x)) if n else None, "s": None, "cp": None,
           "cp_ci": None, "cpk": None, "cpk_ci": None, "confidence": confidence,
           "stated": stated, "reason": None if stated else
           f"{n} value(s) are too few to state Cp/Cpk (at least {MIN_CAPABILITY_N})",
           "method": "Cp: chi-square interval; Cpk: Bissell (1990) normal approximation"}
    if n < 2 or (lower is None and upper is None):
        return out
    s = float(np.std(x, ddof=1))
    out["s"] = s
    if s == 0:
        return out
    alpha = 1 - confidence
    mean = out["mean"]
    if lower is not None and upper is not None:
        cp = (upper - lower) / (6 * s)
        out["cp"] = cp
        out["cp_ci"] = [cp * math.sqrt(chi2.ppf(alpha / 2, n - 1) / (n - 1)),
                        cp * math.sqrt(chi2.ppf(1 - alpha / 2, n - 1) / (n - 1))]
    sides = [(upper - mean) if upper is not None else math.inf,
             (mean - lower) if lower is not None else math.inf]
    cpk = min(sides) / (3 * s)
    half = norm.ppf(1 - alpha / 2) * math.sqrt(1 / (9 * n) + cpk ** 2 / (2 * (n - 1)))
    out["cpk"] = cpk
    out["cpk_ci"] = [cpk - half, cpk + half]
    return out


def measured_yield(accepted: list[bool], confidence: float = CONFIDENCE) -> dict:
    """Share accepted with its Clopper–Pearson interval."""
    from hil.tolerance.stats import yield_interval

    n = len(accepted)
    passed = int(sum(bool(a) for a in accepted))
    if n == 0:
        return {"passed": 0, "total": 0, "yield": None, "ci": None}
    low, high = yield_interval(passed, n, confidence)
    return {"passed": passed, "total": n, "yield": passed / n, "ci": [low, high],
            "method": "Clopper-Pearson"}
