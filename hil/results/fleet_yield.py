"""Close the loop (issue 24 item 4): tolerance distributions fitted to the diagnosed units in the
results database, and the yield those units measured.

Each unit (DUT serial) counts once, with its newest diagnosed run. For each controller parameter
the diagnosis estimates (``hil.diagnosis``: ``ia_offset_a``, ``ib_offset_a`` in A, ``gain_k_diff``
= k_a − k_b per unit, ``dead_time_us`` in µs; eqs 15–26 and 32–38) over the units give a mean and
a sample standard deviation s; the spread of the parameter itself is s with the estimates' own
measurement scatter removed in quadrature, σ = √max(s² − mean(u²), 0) (a unit's estimate is the
true value plus an error of standard uncertainty u). Fitted as normals; the gain difference is
split into two independent sensor errors ±(mean/2) with σ/√2 each (only k_a − k_b moves the
ripple, eqs 21–26). The measured yield is the share of units whose newest run with the
requirement accepted it at every point, with its Clopper–Pearson interval.
"""

from __future__ import annotations

import dataclasses
import math

from hil.errors import InputError
from hil.results.capability import measured_yield
from hil.results.schema import diagnosis_estimates, requirement_verdicts, runs

#: Diagnosis parameter → (tolerance parameters it sets, scale to their unit).
FITTED = {"ia_offset_a": 1.0, "ib_offset_a": 1.0, "gain_k_diff": 1.0, "dead_time_us": 1e-6}
MIN_UNITS = 3


def _newest_per_unit(rows) -> dict:
    chosen: dict = {}
    for row in rows:                               # ordered oldest first: the last one wins
        chosen.setdefault(row.dut_serial, {})[row.record_id] = row
    return {dut: list(by_run.values()) for dut, by_run in chosen.items()}


def fit_parameters(engine) -> dict[str, dict]:
    """Per diagnosis parameter: units, mean, s, mean u, σ (see the module docstring)."""
    from sqlalchemy import select

    query = (select(diagnosis_estimates, runs.c.dut_serial, runs.c.created_utc)
             .join(runs, runs.c.record_id == diagnosis_estimates.c.record_id)
             .where(diagnosis_estimates.c.name.in_(list(FITTED)),
                    diagnosis_estimates.c.estimate.is_not(None),
                    diagnosis_estimates.c.identifiable.is_(True))
             .order_by(runs.c.created_utc, runs.c.record_id))
    with engine.connect() as connection:
        rows = list(connection.execute(query))
    newest: dict[tuple, object] = {}
    for row in rows:
        newest[(row.name, row.dut_serial)] = row
    fits = {}
    for name in FITTED:
        values = [r.estimate for (n, _), r in newest.items() if n == name]
        us = [r.standard_uncertainty or 0.0 for (n, _), r in newest.items() if n == name]
        if len(values) < MIN_UNITS:
            continue
        mean = sum(values) / len(values)
        s = math.sqrt(sum((v - mean) ** 2 for v in values) / (len(values) - 1))
        u2 = sum(u * u for u in us) / len(us)
        fits[name] = {"units": len(values), "mean": mean, "s": s, "mean_u": math.sqrt(u2),
                      "sigma": math.sqrt(max(s * s - u2, 0.0))}
    return fits


def fitted_spec(spec, fits: dict[str, dict]):
    """``spec`` with the parameters the fits cover replaced by fitted normals."""
    from hil.tolerance.distributions import Normal
    from hil.tolerance.spec import PARAMETERS

    if not fits:
        raise InputError(f"--from-db: no parameter has diagnosis estimates from at least "
                         f"{MIN_UNITS} units in the results database")

    def normal(name, mean, sigma):
        info = PARAMETERS[name]
        return Normal(mean, sigma, info.low, info.high)

    params = dict(spec.parameters)
    for name, fit in fits.items():
        scale = FITTED[name]
        if name == "gain_k_diff":
            half = fit["sigma"] / math.sqrt(2)
            params["ia_gain_error_pu"] = normal("ia_gain_error_pu", fit["mean"] / 2, half)
            params["ib_gain_error_pu"] = normal("ib_gain_error_pu", -fit["mean"] / 2, half)
        elif name == "dead_time_us":
            params["dead_time_s"] = normal("dead_time_s", fit["mean"] * scale,
                                           fit["sigma"] * scale)
        else:
            params[name] = normal(name, fit["mean"], fit["sigma"])
    given = tuple(sorted(set(spec.given) | set(params)))
    return dataclasses.replace(spec, parameters=params, given=given)


def unit_yield(engine, requirement_id: str) -> dict:
    """Measured yield of ``requirement_id`` over units (each unit's newest run judging it)."""
    from sqlalchemy import select

    query = (select(requirement_verdicts.c.record_id, requirement_verdicts.c.accepted,
                    runs.c.dut_serial)
             .join(runs, runs.c.record_id == requirement_verdicts.c.record_id)
             .where(requirement_verdicts.c.requirement_id == requirement_id)
             .order_by(runs.c.created_utc, runs.c.record_id))
    with engine.connect() as connection:
        rows = list(connection.execute(query))
    per_unit: dict[str, tuple[str, bool]] = {}
    for row in rows:
        record, ok = per_unit.get(row.dut_serial, (None, True))
        if record != row.record_id:                 # a newer run of this unit: start again
            ok = True
        per_unit[row.dut_serial] = (row.record_id, ok and bool(row.accepted))
    result = measured_yield([ok for _, ok in per_unit.values()])
    result["requirement"] = requirement_id
    return result
