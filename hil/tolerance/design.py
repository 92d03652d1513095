"""Inverse design: the loosest tolerances that reach a target yield (closed-form engine).

Variables: one spread factor f_p per toleranced parameter p (normal σ or uniform ± half width;
fixed and choice parameters are not design variables), on the geometric ladder
f = 2^(k/4), k = −24..+8 (1/64 … 4× the file's tolerance). Cost: Σ_p w_p / f_p — a tolerance
costs in inverse proportion to its width, the file's tolerances costing w_p each (w_p = 1
unless given). Yield: the passing fraction of a fixed sample of drives (common random numbers:
the same uniforms u mapped through each candidate's inverse CDFs, so yield differences between
candidates are not sampling noise); a candidate reaches the target when the lower end of its
95 % Clopper–Pearson interval on that sample does (a margin for the sample's own noise).

Algorithm (greedy marginal cost, a heuristic — no global optimality claimed):
1. tighten: while yield < target, take one ladder step down on the parameter with the largest
   yield gain per unit of cost added (if no single step gains, step every parameter down);
   infeasible if all are at the bottom of the ladder;
2. loosen: repeatedly take one ladder step up on the parameter whose step saves the most cost
   while the yield stays ≥ target; stop when no step does.
Also, per parameter alone (others at the file's tolerances): the loosest factor on the ladder
that reaches the target, or none. The chosen design is then checked on a fresh Monte Carlo
sample (another seed) so its stated yield is not the one it was optimised on.
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

from hil.errors import InputError
from hil.tolerance.combiner import CombinerSettings
from hil.tolerance.distributions import Normal, Uniform
from hil.tolerance.engines import closed_form_ripple, parameters_from_unit
from hil.tolerance.spec import ToleranceSpec
from hil.tolerance.stats import yield_interval

STEPS_PER_OCTAVE = 4
K_MIN, K_MAX = -24, 8


def factor(k: int) -> float:
    return 2.0 ** (k / STEPS_PER_OCTAVE)


def toleranced(spec: ToleranceSpec) -> list[str]:
    return [name for name, dist in spec.parameters.items()
            if isinstance(dist, (Normal, Uniform)) and dist.spread > 0]


def yield_function(spec: ToleranceSpec, drives: int, seed: int,
                   settings: CombinerSettings) -> Callable[[dict[str, float]], float]:
    """The lower end of the 95 % Clopper–Pearson interval of yield(factors) on a fixed sample
    of uniforms (common random numbers): a design must reach the target with that margin."""
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(2**31,)))
    unit = {name: rng.random(drives) for name in spec.varied}
    limit_pu = spec.requirement.limit_pu

    def evaluate(factors: dict[str, float]) -> float:
        scaled = spec.with_spreads(factors)
        params = parameters_from_unit(scaled, unit, drives)
        ripple = closed_form_ripple(spec.operating_points, params, drives, settings)
        return yield_interval(int(np.count_nonzero(spec.worst_pu(ripple) <= limit_pu)), drives)[0]

    return evaluate


def inverse_design(spec: ToleranceSpec, target_yield: float, *, drives: int = 20_000,
                   seed: int | None = None, weights: dict[str, float] | None = None,
                   settings: CombinerSettings = CombinerSettings(),
                   check_drives: int = 200_000) -> dict:
    """The loosest tolerances reaching ``target_yield`` (fraction) — module docstring."""
    if not 0.0 < target_yield < 1.0:
        raise InputError(f"--target-yield {100 * target_yield:g} % must be in (0, 100) %")
    spec = spec.with_requirement()
    names = toleranced(spec)
    if not names:
        raise InputError("inverse design needs at least one normal or uniform tolerance")
    weights = {name: 1.0 for name in names} | (weights or {})
    unknown = sorted(set(weights) - set(names))
    if unknown:
        raise InputError(f"--cost-weight {unknown[0]}: not a toleranced parameter "
                         f"(allowed: {', '.join(names)})")
    seed = spec.seed if seed is None else seed
    evaluate = yield_function(spec, drives, seed, settings)
    ks = {name: 0 for name in names}
    cost = lambda kk: math.fsum(weights[n] / factor(kk[n]) for n in names)  # noqa: E731
    memo: dict[tuple, float] = {}

    def at(kk: dict[str, int]) -> float:
        key = tuple(kk[n] for n in names)
        if key not in memo:
            memo[key] = evaluate({n: factor(kk[n]) for n in names})
        return memo[key]

    start_yield = current = at(ks)
    steps: list[dict] = []
    while current < target_yield:
        options = []
        for name in names:
            if ks[name] > K_MIN:
                trial = ks | {name: ks[name] - 1}
                gain = at(trial) - current
                options.append((gain / (cost(trial) - cost(ks)), gain, name, trial))
        if not options:
            return {"feasible": False, "target_yield": target_yield,
                    "start_yield_lower95": start_yield,
                    "reason": f"yield {100 * current:.3g} % with every tolerance at 1/"
                              f"{1 / factor(K_MIN):g} of the file's: the fixed parameters or "
                              "the choices alone miss the limit", "steps": steps}
        best = max(options)
        if best[1] <= 0:
            trial = {n: max(K_MIN, k - 1) for n, k in ks.items()}
            name = "all"
        else:
            _, _, name, trial = best
        ks, current = trial, at(trial)
        steps.append({"phase": "tighten", "parameter": name, "yield": current})
    improved = True
    while improved:
        improved = False
        options = []
        for name in names:
            if ks[name] < K_MAX:
                trial = ks | {name: ks[name] + 1}
                value = at(trial)
                if value >= target_yield:
                    options.append((cost(ks) - cost(trial), name, trial, value))
        if options:
            _, name, trial, value = max(options)
            ks, current, improved = trial, value, True
            steps.append({"phase": "loosen", "parameter": name, "yield": current})
    alone = {}
    for name in names:
        best_k = _loosest_alone(lambda k: at({n: 0 for n in names} | {name: k}), target_yield)
        dist = spec.parameters[name]
        alone[name] = None if best_k is None else {
            "factor": factor(best_k), "spread": dist.spread * factor(best_k),
            "spread_kind": "sigma" if isinstance(dist, Normal) else "half_width"}
    design = spec.with_spreads({n: factor(k) for n, k in ks.items()})
    check = _fresh_check(design, check_drives, seed, settings)
    return {
        "feasible": True, "target_yield": target_yield, "start_yield_lower95": start_yield,
        "design_drives": drives, "cost_weights": weights,
        "cost": {"file": cost({n: 0 for n in names}), "design": cost(ks)},
        "algorithm": "greedy marginal cost on a 2^(k/4) ladder with common random numbers "
                     "(hil/tolerance/design.py)",
        "parameters": {n: {"factor": factor(ks[n]),
                           "file_spread": spec.parameters[n].spread,
                           "design_spread": design.parameters[n].spread,
                           "spread_kind": "sigma" if isinstance(spec.parameters[n], Normal)
                           else "half_width"} for n in names},
        "design_yield_lower95_on_design_sample": current, "check": check, "alone": alone, "steps": steps}


def _loosest_alone(yield_at: Callable[[int], float], target: float) -> int | None:
    """Largest ladder step k whose yield reaches ``target``, by bisection (the yield taken as
    non-increasing in k); None if even the tightest step misses it."""
    if yield_at(K_MIN) < target:
        return None
    if yield_at(K_MAX) >= target:
        return K_MAX
    low, high = K_MIN, K_MAX  # yield_at(low) passes, yield_at(high) fails
    while high - low > 1:
        middle = (low + high) // 2
        if yield_at(middle) >= target:
            low = middle
        else:
            high = middle
    return low


def _fresh_check(spec: ToleranceSpec, drives: int, seed: int, settings: CombinerSettings) -> dict:
    """The design's yield on an independent Monte Carlo sample, with its 95 % interval."""
    from hil.tolerance.engines import sample_parameters
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(2**31 + 1,)))
    params = sample_parameters(spec, rng, drives)
    ripple = closed_form_ripple(spec.operating_points, params, drives, settings)
    passed = int(np.count_nonzero(spec.worst_pu(ripple) <= spec.requirement.limit_pu))
    return {"drives": drives, "yield": passed / drives,
            "yield_ci95": list(yield_interval(passed, drives))}
