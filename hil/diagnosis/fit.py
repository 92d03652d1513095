"""Weighted linear least squares on complex order coefficients, with covariance and
identifiability from the singular values of the weighted, column-scaled Jacobian.

The model is linear in its parameters: y(s, m) = Σ_j J[s, m, j]·p_j with y the measured complex
coefficient of spectrum s at mechanical order m. Each complex row gives two real rows. Weights:
1/σ² with σ² = (type-A)² + Σ_j (u_rel,j·|J·p_j|)²/2 — the model uncertainty of each source,
relative to its own contribution, so the weights are refined from the estimate (a few fixed-point
iterations). The covariance is the type-A noise and half of the model variance (the part that
differs from point to point) propagated through that estimator, scaled by the Birge ratio χ²/ν
when that exceeds 1 (the data disagree with the model more than the stated uncertainties allow),
plus the other half propagated as an error *common to all points* (a source's model wrong the
same way at every point, which averaging points does not reduce): :func:`_systematic_covariance`.
Terms known only by a bound (:class:`SystematicTerm`, e.g. a coarse encoder's dwells,
hil.diagnosis.dwell) widen the covariance the same way, without entering the weights.

Identifiability: columns of the weighted Jacobian are scaled to unit norm; a singular value below
:data:`WEAK_SINGULAR_VALUE` of the largest marks a parameter combination these observations cannot
determine (its right singular vector); parameters with a loading above :data:`WEAK_LOADING` in such
a direction are reported as not identifiable; the stated estimates leave that direction out
(truncated SVD) so the rest stays determined, while the residual and the sources' torque use the
full least-squares solution (the torque the weak combination shares is fitted, not left over).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

#: Relative singular value below which a parameter combination counts as not determined: with
#: unit-norm columns, signatures that differ by less than ~5 % across the points are told apart
#: only by the loop and transducer corrections (a few % of a signature, themselves uncertain by
#: a fifth: hil.diagnosis.parameters), so such a separation is not trusted.
WEAK_SINGULAR_VALUE = 0.05
#: Loading of a parameter in a weak direction above which it is reported as not identifiable.
WEAK_LOADING = 0.1
MODEL_WEIGHT_ITERATIONS = 4
#: Coverage factor the alternatives' shifts are kept within (the diagnosis states U at k = 2).
ALTERNATIVES_K = 2.0
#: Share of a source's model variance taken as differing from point to point; the rest is common
#: to all points. Unknown, so split evenly.
COMMON_SHARE_COMPLEMENT = 0.5


@dataclass
class LinearProblem:
    """Complex observations y (n), their type-A σ per component (n), the complex Jacobian J (n×p),
    the relative model uncertainty per observation and parameter (n×p), and row labels."""

    names: list[str]
    y: np.ndarray
    sigma: np.ndarray
    jacobian: np.ndarray
    model_rel: np.ndarray
    rows: list[tuple[int, int]] = field(default_factory=list)   # (spectrum index, mech order)
    #: Terms not fitted but bounded: their torque only widens the covariance (SystematicTerm).
    systematic: list["SystematicTerm"] = field(default_factory=list)
    #: Alternative Jacobians (e.g. the forward model through other plausible current loops):
    #: the problem is re-solved with each and Σ_v δ_v·δ_vᵀ / k² of the solution's shifts δ_v is
    #: added to the covariance (the drive has one of them, which is not known: every
    #: alternative's shift lies within U = k·u of each parameter, k = :data:`ALTERNATIVES_K`);
    #: the estimates stay those of ``jacobian``. Not linearised: a signature whose scale differs
    #: by a factor between the alternatives moves its parameter by that factor.
    alternatives: list[np.ndarray] = field(default_factory=list)


@dataclass
class SystematicTerm:
    """An unmodelled contribution known only by a bound: its torque per unit (complex, per
    observation row) and the standard uncertainty of that unit, propagated through the
    estimator as an error common to all points (``common``) or, like the sources' model
    uncertainty, half common and half independent from point to point
    (:data:`COMMON_SHARE_COMPLEMENT`); it changes neither the weights nor the estimates."""

    name: str
    rows: np.ndarray
    standard_uncertainty: float
    common: bool = True


@dataclass
class FitResult:
    names: list[str]
    estimate: np.ndarray                 # NaN where not identifiable
    covariance: np.ndarray               # NaN rows/cols where not identifiable
    identifiable: np.ndarray
    chi2: float
    dof: int
    birge_ratio: float
    singular_values_rel: np.ndarray
    weak_directions: list[dict]
    condition_number: float
    residual: np.ndarray                 # complex, per observation row
    sigma_total: np.ndarray              # per component, per observation row
    fitted_contributions: np.ndarray     # complex n×p: J·p of the full least-squares solution
    #: the truncated-SVD solution without NaN (weak directions at their minimum-norm share)
    solution: np.ndarray = None

    def standard_uncertainty(self) -> np.ndarray:
        return np.sqrt(np.diag(self.covariance))

    def correlation(self) -> np.ndarray:
        u = self.standard_uncertainty()
        with np.errstate(invalid="ignore", divide="ignore"):
            return self.covariance / np.outer(u, u)


def _real_system(problem: LinearProblem, sigma_total: np.ndarray):
    """The weighted real system: Re rows then Im rows, each divided by its σ."""
    weights = np.concatenate([sigma_total, sigma_total])
    a = np.concatenate([problem.jacobian.real, problem.jacobian.imag]) / weights[:, None]
    b = np.concatenate([problem.y.real, problem.y.imag]) / weights
    return a, b


#: An entry of a column below this fraction of the column's largest is numerical noise (e.g. an
#: FFT's round-off at an order a source does not act on): it does not couple parameters.
COUPLING_FLOOR = 1e-9


def _blocks(scaled: np.ndarray) -> list[np.ndarray]:
    """Column indices grouped by shared observations (parameters acting on disjoint rows are
    judged separately, so a weak direction names only parameters that can trade off)."""
    size = scaled.shape[1]
    acts = np.abs(scaled) > COUPLING_FLOOR * np.max(np.abs(scaled), axis=0, initial=0.0)
    parent = list(range(size))

    def root(j):
        while parent[j] != j:
            parent[j] = parent[parent[j]]
            j = parent[j]
        return j

    for row in acts:
        cols = np.flatnonzero(row)
        for j in cols[1:]:
            parent[root(j)] = root(cols[0])
    groups: dict[int, list[int]] = {}
    for j in range(size):
        groups.setdefault(root(j), []).append(j)
    return [np.array(g) for g in groups.values()]


def identifiability(weighted: np.ndarray, names: list[str]):
    """(relative singular values, weak directions, identifiable mask, column norms, condition).

    Singular values are relative to the largest of the whole (column-scaled) system; weak
    directions are found per block of parameters that share observations, with the full right
    singular basis: with fewer real observations than parameters in a block, the directions
    beyond its rank have no singular value in a thin SVD and count as 0 (not determined)."""
    norms = np.linalg.norm(weighted, axis=0)
    dead = norms == 0
    scaled = weighted / np.where(dead, 1.0, norms)
    s_all = np.linalg.svd(scaled, compute_uv=False)
    top = s_all[0] if s_all.size and s_all[0] > 0 else 1.0
    s_rel_all = []
    weak = []
    identifiable = ~dead
    for block in _blocks(scaled):
        block = np.array([j for j in block if not dead[j]])
        if block.size == 0:
            continue
        _, s_thin, vt = np.linalg.svd(scaled[:, block], full_matrices=True)
        s = np.zeros(vt.shape[0])
        s[:s_thin.size] = s_thin
        s_rel = s / top
        s_rel_all.extend(s_rel.tolist())
        for index, value in enumerate(s_rel):
            if value >= WEAK_SINGULAR_VALUE:
                continue
            vector = vt[index]
            loaded = np.abs(vector) > WEAK_LOADING
            if not loaded.any():
                continue
            identifiable[block[loaded]] = False
            weak.append({"singular_value_rel": float(value),
                         "combination": {names[block[j]]: float(vector[j])
                                         for j in np.flatnonzero(loaded)}})
    for j in np.flatnonzero(dead):
        weak.append({"singular_value_rel": 0.0, "combination": {names[j]: 1.0},
                     "reason": "no observation at the orders this parameter acts on"})
    s_rel = np.sort(np.array(s_rel_all))[::-1]
    live = s_rel[s_rel >= WEAK_SINGULAR_VALUE]
    condition = float(live[0] / live[-1]) if live.size else float("inf")
    return s_rel, _merge(weak), identifiable, norms, condition


def _merge(weak: list[dict]) -> list[dict]:
    """Weak directions of one block that share parameters are one statement (the basis of a
    null space is arbitrary; the parameters it involves are not)."""
    out: list[dict] = []
    for item in weak:
        for other in out:
            if "reason" not in item and "reason" not in other and \
                    set(other["combination"]) & set(item["combination"]):
                other["combination"].update({k: v for k, v in item["combination"].items()
                                             if k not in other["combination"]})
                other["singular_value_rel"] = min(other["singular_value_rel"],
                                                  item["singular_value_rel"])
                break
        else:
            out.append({**item, "combination": dict(item["combination"])})
    return out


def _solve(a: np.ndarray, b: np.ndarray, live: np.ndarray):
    """Truncated-SVD least squares over the ``live`` columns (column-scaled): directions with a
    relative singular value below :data:`WEAK_SINGULAR_VALUE` are left out, so a combination the
    data cannot determine gets its minimum-norm share (its torque is still accounted for) without
    blowing up the rest. Returns (solution, covariance, operator M with solution = M·b, full
    solution): the full least-squares solution (weak directions included) is what the residual
    and the sources' torque use, so a weak direction's share is fitted, not left as residual."""
    size = a.shape[1]
    x = np.zeros(size)
    cov = np.zeros((size, size))
    operator = np.zeros((size, a.shape[0]))
    if not live.any():
        return x, cov, operator, 0
    sub = a[:, live]
    norms = np.linalg.norm(sub, axis=0)
    u, s, vt = np.linalg.svd(sub / norms, full_matrices=False)
    kept = s >= WEAK_SINGULAR_VALUE * s[0]
    v = vt[kept].T / norms[:, None]
    m = v @ (u[:, kept].T / s[kept][:, None])
    operator[live] = m
    x = operator @ b
    cov[np.ix_(live, live)] = (v / s[kept] ** 2) @ v.T
    full = np.zeros(size)
    full[live] = np.linalg.lstsq(sub / norms, b, rcond=1e-12)[0] / norms
    return x, cov, operator, full


def _systematic_covariance(problem: LinearProblem, p: np.ndarray, operator: np.ndarray,
                           sigma_total: np.ndarray) -> np.ndarray:
    """Covariance of the estimates from each source's model error taken as *common* to all
    points (a relative error ε_j of its signature, complex: scale and phase, each of standard
    uncertainty u_rel/√2): the sensitivity of the estimates to ε_j, times its variance."""
    size = len(problem.names)
    cov = np.zeros((size, size))
    weights = np.concatenate([sigma_total, sigma_total])
    for j in range(size):
        error = problem.model_rel[:, j] * problem.jacobian[:, j] * p[j]
        if not np.any(error):
            continue
        for part in (error, 1j * error):
            shift = operator @ (np.concatenate([part.real, part.imag]) / weights)
            cov += 0.5 * np.outer(shift, shift)
    return cov


def _bounded_covariance(problem: LinearProblem, operator: np.ndarray,
                        sigma_total: np.ndarray) -> np.ndarray:
    """Covariance of the estimates from the problem's :class:`SystematicTerm` s."""
    size = len(problem.names)
    cov = np.zeros((size, size))
    weights = np.concatenate([sigma_total, sigma_total])
    points = np.array([row[0] for row in problem.rows]) if problem.rows else None
    for term in problem.systematic:
        def shift(rows):
            return operator @ (np.concatenate([rows.real, rows.imag]) / weights)
        variance = term.standard_uncertainty ** 2
        share = 0.0 if term.common else COMMON_SHARE_COMPLEMENT
        common = shift(term.rows)
        cov += (1.0 - share) * variance * np.outer(common, common)
        if share and points is not None:
            for point in np.unique(points):
                alone = shift(np.where(points == point, term.rows, 0j))
                cov += share * variance * np.outer(alone, alone)
    return cov


def _alternatives_covariance(problem: LinearProblem, sigma_total: np.ndarray, live: np.ndarray,
                             x: np.ndarray) -> np.ndarray:
    """Σ_v δ_v·δ_vᵀ / k² of the solution's shifts δ_v when ``jacobian`` is replaced by each of
    ``problem.alternatives`` (same weights, same truncation): each |δ_v,j| ≤ k·u_j."""
    size = len(problem.names)
    cov = np.zeros((size, size))
    for jacobian in problem.alternatives:
        a, b = _real_system(replace(problem, jacobian=jacobian), sigma_total)
        shift = _solve(a, b, live)[0] - x
        cov += np.outer(shift, shift) / ALTERNATIVES_K ** 2
    return cov


def fit(problem: LinearProblem) -> FitResult:
    """Solve ``problem`` (module docstring)."""
    sigma_total = problem.sigma.copy()
    live = np.any(problem.jacobian != 0, axis=0)
    for _ in range(MODEL_WEIGHT_ITERATIONS):
        a, b = _real_system(problem, sigma_total)
        x, cov, operator, full = _solve(a, b, live)
        contributions = problem.jacobian * full[None, :]
        model_var = 0.5 * np.sum((problem.model_rel * np.abs(contributions)) ** 2, axis=1)
        sigma_total = np.sqrt(problem.sigma ** 2 + model_var)
    a, b = _real_system(problem, sigma_total)
    # identifiability judged with the full uncertainties (type A and model) of each observation
    s_rel, weak, keep, _, condition = identifiability(a, problem.names)
    x, cov, operator, full = _solve(a, b, live)
    contributions = problem.jacobian * full[None, :]
    residual = problem.y - contributions.sum(axis=1)
    chi2 = float(np.sum((residual.real / sigma_total) ** 2 + (residual.imag / sigma_total) ** 2))
    dof = 2 * len(problem.y) - int(live.sum())
    birge = chi2 / dof if dof > 0 else float("nan")
    # Through the estimator: type A, plus the model uncertainty split evenly (its split is not
    # known) into a part that differs from point to point (like noise) and a part common to all
    # points (a source's model wrong the same way everywhere, not reduced by averaging points)
    model_var = sigma_total ** 2 - problem.sigma ** 2
    noise_var = problem.sigma ** 2 + COMMON_SHARE_COMPLEMENT * model_var
    share = np.sqrt(np.concatenate([noise_var, noise_var])) / np.concatenate([sigma_total,
                                                                              sigma_total])
    cov = (operator * share ** 2) @ operator.T
    if dof > 0 and birge > 1.0:
        cov = cov * birge
    cov = cov + (1.0 - COMMON_SHARE_COMPLEMENT) * _systematic_covariance(problem, full, operator,
                                                                         sigma_total)
    cov = cov + _bounded_covariance(problem, operator, sigma_total)
    cov = cov + _alternatives_covariance(problem, sigma_total, live, x)
    estimate = np.where(keep, x, np.nan)
    cov[~keep, :] = np.nan
    cov[:, ~keep] = np.nan
    return FitResult(names=list(problem.names), estimate=estimate, covariance=cov,
                     identifiable=keep, chi2=chi2, dof=dof, birge_ratio=birge,
                     singular_values_rel=s_rel, weak_directions=weak,
                     condition_number=condition, residual=residual, sigma_total=sigma_total,
                     fitted_contributions=contributions, solution=x)
