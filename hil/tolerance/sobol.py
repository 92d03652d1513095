"""Global sensitivity: Sobol' indices (SALib, Saltelli/Jansen estimators) of the tolerances.

Inputs are the varied parameters, each sampled as u ∈ [0, 1) by SALib's scrambled Sobol'
sequence (N·(D + 2) rows, no second-order indices) and mapped through the parameter's inverse
CDF (so normal, uniform and choice distributions are honoured). Two outputs are analysed:

* ``ripple`` — the worst pk-pk over the operating points, % of the mean torque;
* ``failure`` — the indicator of exceeding the limit at any point: its total index S_T says
  how much of the pass/fail variance each tolerance explains, i.e. which one drives failures.

The ranking uses S_T of ``failure`` when failures vary across the sample, else of ``ripple``.
Where the 95 % intervals (SALib's bootstrap, S_T ± ST_conf) of two adjacent ranks overlap, the
sample does not resolve their order: ``unresolved`` lists those pairs (more base samples would).
"""

from __future__ import annotations

from typing import Callable

import numpy as np
from SALib.analyze import sobol as sobol_analyze
from SALib.sample import sobol as sobol_sample

from hil.errors import InputError


def sobol_sample_unit(names: list[str], base_samples: int, seed: int) -> np.ndarray:
    """SALib's Saltelli matrix over [0, 1)^D for ``names``: N·(D + 2) rows."""
    if len(names) < 1:
        raise InputError("Sobol' indices need at least one varied parameter")
    if base_samples < 8 or base_samples & (base_samples - 1):
        raise InputError(f"--sobol-n {base_samples} must be a power of 2 >= 8")
    problem = {"num_vars": len(names), "names": list(names), "bounds": [[0.0, 1.0]] * len(names)}
    unit = sobol_sample.sample(problem, base_samples, calc_second_order=False, seed=seed)
    return np.clip(unit, 0.0, np.nextafter(1.0, 0.0))


def sobol_indices(names: list[str], outputs: dict[str, np.ndarray], seed: int) -> dict:
    """S1, ST and their 95 % confidence half-widths per output, and the ranking."""
    problem = {"num_vars": len(names), "names": list(names), "bounds": [[0.0, 1.0]] * len(names)}
    indices = {}
    for label, values in outputs.items():
        values = np.asarray(values, dtype=float)
        if np.var(values) == 0.0:
            indices[label] = None  # constant output: nothing to apportion
            continue
        result = sobol_analyze.analyze(problem, values, calc_second_order=False, seed=seed,
                                       print_to_console=False)
        indices[label] = {name: {"S1": float(result["S1"][i]), "S1_conf": float(result["S1_conf"][i]),
                                 "ST": float(result["ST"][i]), "ST_conf": float(result["ST_conf"][i])}
                          for i, name in enumerate(names)}
    basis = "failure" if indices.get("failure") else "ripple"
    ranking = sorted(names, key=lambda n: -indices[basis][n]["ST"]) if indices.get(basis) else []
    unresolved = [[a, b] for a, b in zip(ranking, ranking[1:])
                  if _low(indices[basis][a]) <= _high(indices[basis][b])]
    return {"indices": indices, "ranked_by": f"ST of {basis}", "ranking": ranking,
            "unresolved": unresolved}


def _low(row: dict) -> float:
    return row["ST"] - row["ST_conf"]


def _high(row: dict) -> float:
    return row["ST"] + row["ST_conf"]


def run_sobol(names: list[str], base_samples: int, seed: int,
              evaluate: Callable[[dict[str, np.ndarray]], np.ndarray], limit_pct: float) -> dict:
    """Sample, evaluate (``evaluate(unit_columns) -> worst ripple %`` per row), analyse."""
    unit = sobol_sample_unit(names, base_samples, seed)
    ripple_pct = np.asarray(evaluate({name: unit[:, i] for i, name in enumerate(names)}))
    failure = (ripple_pct > limit_pct).astype(float)
    out = sobol_indices(names, {"ripple": ripple_pct, "failure": failure}, seed)
    out.update(base_samples=base_samples, evaluations=int(unit.shape[0]),
               failure_fraction=float(failure.mean()))
    return out
