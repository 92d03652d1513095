"""The predicted yield of a fleet fitted from n units, with the uncertainty of the fit itself
(issue 32 item 5): a 95 % interval that covers what n units cannot pin down, not only the Monte
Carlo error of the fitted point values.

Model (``fleet_yield.py``): a unit's estimate is x_i = θ_i + e_i with θ_i ~ N(μ, σ²) and
e_i ~ N(0, u_i²), so x_i ~ N(μ, τ²) with τ² = σ² + mean(u²). With the reference prior
p(μ, τ²) ∝ 1/τ² the posterior is τ² ~ (n−1)·s² / χ²_{n−1} and μ | τ² ~ N(x̄, τ²/n) (Gelman et
al., Bayesian Data Analysis, §3.2). Each of ``draws`` posterior draws (μ_b, σ_b = √max(τ_b² −
mean(u²), 0)) of every fitted parameter gives a tolerance spec; its yield is the share of
``drives_per_draw`` closed-form drives whose worst judged pk-pk is within the limit. The
predicted yield is the mean over draws and the interval the draws' 2.5 and 97.5 percentiles.

When n is too small to state a yield: the posterior of τ² (scaled inverse χ² with ν = n − 1
degrees of freedom) has a finite variance only for ν > 4, i.e. from :data:`MIN_STATED_UNITS`
units on; below that the yield is not stated (the interval is still given, as the reason).
"""

from __future__ import annotations

import math

import numpy as np

#: Fewest units (of the fewest-fitted parameter) for which a predicted yield is stated.
MIN_STATED_UNITS = 6
DRAWS = 200
DRIVES_PER_DRAW = 2000
#: Drives per closed-form pass (bounds the memory of one pass).
CHUNK = 50_000


def posterior_fit(fit: dict, rng: np.random.Generator) -> dict:
    """One posterior draw of a ``fit_parameters`` entry (its mean and σ replaced)."""
    n, s, mean_u = fit["units"], fit["s"], fit["mean_u"]
    tau2 = (n - 1) * s * s / rng.chisquare(n - 1)
    mu = rng.normal(fit["mean"], math.sqrt(tau2 / n))
    return fit | {"mean": float(mu), "sigma": math.sqrt(max(tau2 - mean_u * mean_u, 0.0))}


def _worst_pu(spec, params: dict, drives: int, settings) -> np.ndarray:
    """Each drive's worst judged pk-pk (closed form), in chunks of at most CHUNK drives."""
    from hil.tolerance.combiner import CombinerSettings
    from hil.tolerance.engines import closed_form_ripple

    out = []
    for start in range(0, drives, CHUNK):
        n = min(CHUNK, drives - start)
        chunk = {name: values[start:start + n] for name, values in params.items()}
        out.append(spec.worst_pu(closed_form_ripple(spec.operating_points, chunk, n,
                                                    settings or CombinerSettings())))
    return np.concatenate(out)


def spec_yield(spec, rng: np.random.Generator, drives: int, settings=None) -> float:
    """Share of ``drives`` closed-form drives of ``spec`` within its requirement's limit
    (``settings``: the combiner's, as ``hil yield`` runs it)."""
    from hil.tolerance.engines import sample_parameters

    params = sample_parameters(spec, rng, drives)
    return float(np.mean(_worst_pu(spec, params, drives, settings) <= spec.requirement.limit_pu))


def predicted_yield(spec, fits: dict[str, dict], *, draws: int = DRAWS,
                    drives_per_draw: int = DRIVES_PER_DRAW, seed: int = 0,
                    settings=None) -> dict:
    """The predicted yield over the posterior of the fits (module docstring); ``spec`` is the
    tolerance spec the fits replace parameters of (``fleet_yield.fitted_spec``). Every draw's
    drives are evaluated together (one closed-form pass over draws × drives_per_draw)."""
    from hil.results.fleet_yield import fitted_spec
    from hil.tolerance.engines import sample_parameters

    rng = np.random.default_rng(seed)
    sampled = [sample_parameters(fitted_spec(spec, {name: posterior_fit(fit, rng)
                                                    for name, fit in fits.items()}),
                                 rng, drives_per_draw) for _ in range(draws)]
    params = {name: np.concatenate([p[name] for p in sampled]) for name in sampled[0]}
    worst = _worst_pu(spec, params, draws * drives_per_draw, settings)
    yields = (worst.reshape(draws, drives_per_draw) <= spec.requirement.limit_pu).mean(axis=1)
    units = min(fit["units"] for fit in fits.values())
    low, high = (float(q) for q in np.percentile(yields, [2.5, 97.5]))
    stated = units >= MIN_STATED_UNITS
    return {"yield": float(yields.mean()) if stated else None,
            "interval95": [low, high], "units": units, "stated": stated,
            "reason": None if stated else
            (f"{units} units are too few to state a yield: the fitted spread's posterior has "
             f"no finite variance below {MIN_STATED_UNITS} units (its 95 % interval would be "
             f"[{100 * low:.1f}, {100 * high:.1f}] %)"),
            "method": f"Bayesian: {draws} posterior draws of (mean, sigma) per fitted "
                      f"parameter x {drives_per_draw} closed-form drives each"}
