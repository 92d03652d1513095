"""Weighted linear least squares on complex order coefficients, with covariance and
identifiability from the singular values of the weighted, column-scaled Jacobian.

The model is linear in its parameters: y(s, m) = Σ_j J[s, m, j]·p_j with y the measured complex
coefficient of spectrum s at mechanical order m. Each complex row gives two real rows. Weights:
1/σ² with σ² = (type-A)² + Σ_j (u_rel,j·|J·p_j|)²/2 — the model uncertainty of each source,
relative to its own contribution, so the weights are refined from the estimate (a few fixed-point
iterations). The covariance (JᵀWJ)⁻¹ is scaled by the Birge ratio χ²/ν when that exceeds 1 (the
data disagree with the model more than the stated uncertainties allow), and the model errors are
also propagated as errors *common to all points* (a source's model is wrong the same way at every
point, so averaging points does not reduce it): see :func:`_systematic_covariance`.

Identifiability: columns of the weighted Jacobian are scaled to unit norm; a singular value below
:data:`WEAK_SINGULAR_VALUE` of the largest marks a parameter combination these observations cannot
determine (its right singular vector); parameters with a loading above :data:`WEAK_LOADING` in such
a direction are reported as not identifiable and left out of the solution (truncated SVD).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

#: Relative singular value below which a parameter combination counts as not determined.
WEAK_SINGULAR_VALUE = 1e-3
#: Loading of a parameter in a weak direction above which it is reported as not identifiable.
WEAK_LOADING = 0.1
MODEL_WEIGHT_ITERATIONS = 4


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
    fitted_contributions: np.ndarray     # complex n×p: J·p (zero where not identifiable)

    def standard_uncertainty(self) -> np.ndarray:
        return np.sqrt(np.diag(self.covariance))

    def correlation(self) -> np.ndarray:
        u = self.standard_uncertainty()
        with np.errstate(invalid="ignore", divide="ignore"):
            return self.covariance / np.outer(u, u)


def _real_system(problem: LinearProblem, sigma_total: np.ndarray):
    a = np.concatenate([problem.jacobian.real, problem.jacobian.imag]) / \
        np.concatenate([sigma_total, sigma_total])[:, None]
    b = np.concatenate([problem.y.real, problem.y.imag]) / np.concatenate([sigma_total, sigma_total])
    return a, b


def identifiability(weighted: np.ndarray, names: list[str]):
    """(relative singular values, weak directions, identifiable mask, column norms, condition)."""
    norms = np.linalg.norm(weighted, axis=0)
    dead = norms == 0
    scaled = weighted / np.where(dead, 1.0, norms)
    _, s, vt = np.linalg.svd(scaled, full_matrices=False)
    s_rel = s / s[0] if s.size and s[0] > 0 else np.zeros_like(s)
    weak = []
    identifiable = ~dead
    for index, value in enumerate(s_rel):
        if value >= WEAK_SINGULAR_VALUE:
            continue
        vector = vt[index]
        loaded = np.abs(vector) > WEAK_LOADING
        if not loaded.any() or (dead[loaded].all()):
            continue
        identifiable &= ~loaded
        weak.append({"singular_value_rel": float(value),
                     "combination": {names[j]: float(vector[j]) for j in np.flatnonzero(loaded)}})
    for j in np.flatnonzero(dead):
        weak.append({"singular_value_rel": 0.0, "combination": {names[j]: 1.0},
                     "reason": "no observation at the orders this parameter acts on"})
    live = s_rel[s_rel >= WEAK_SINGULAR_VALUE]
    condition = float(live[0] / live[-1]) if live.size else float("inf")
    return s_rel, weak, identifiable, norms, condition


def _solve(a: np.ndarray, b: np.ndarray, keep: np.ndarray):
    p = np.full(a.shape[1], np.nan)
    cov = np.full((a.shape[1], a.shape[1]), np.nan)
    if keep.any():
        sub = a[:, keep]
        norms = np.linalg.norm(sub, axis=0)
        scaled = sub / norms
        solution, *_ = np.linalg.lstsq(scaled, b, rcond=None)
        p[keep] = solution / norms
        inverse = np.linalg.pinv(scaled.T @ scaled)
        cov[np.ix_(keep, keep)] = inverse / np.outer(norms, norms)
    return p, cov


def _systematic_covariance(problem: LinearProblem, p: np.ndarray, keep: np.ndarray,
                           sigma_total: np.ndarray) -> np.ndarray:
    """Covariance of the estimates from each source's model error taken as *common* to all
    points (a relative error ε_j of its signature, complex: scale and phase, each of standard
    uncertainty u_rel/√2): the sensitivity of the estimates to ε_j, times its variance."""
    size = len(problem.names)
    cov = np.zeros((size, size))
    if not keep.any():
        return cov
    a, _ = _real_system(problem, sigma_total)
    a = a[:, keep]
    normal_inverse = np.linalg.pinv(a.T @ a)
    weights = np.concatenate([sigma_total, sigma_total])
    for j in np.flatnonzero(keep):
        error = problem.model_rel[:, j] * problem.jacobian[:, j] * p[j]
        if not np.any(error):
            continue
        for part in (error, 1j * error):
            shift = normal_inverse @ (a.T @ (np.concatenate([part.real, part.imag]) / weights))
            full = np.zeros(size)
            full[keep] = shift
            cov += 0.5 * np.outer(full, full)
    return cov


def fit(problem: LinearProblem) -> FitResult:
    """Solve ``problem`` (module docstring)."""
    sigma_total = problem.sigma.copy()
    a, _ = _real_system(problem, sigma_total)
    s_rel, weak, keep, _, condition = identifiability(a, problem.names)
    p = np.zeros(len(problem.names))
    for _ in range(MODEL_WEIGHT_ITERATIONS):
        a, b = _real_system(problem, sigma_total)
        p, cov = _solve(a, b, keep)
        contributions = problem.jacobian * np.where(keep, p, 0.0)[None, :]
        model_var = 0.5 * np.sum((problem.model_rel * np.abs(contributions)) ** 2, axis=1)
        sigma_total = np.sqrt(problem.sigma ** 2 + model_var)
    a, b = _real_system(problem, sigma_total)
    p, cov = _solve(a, b, keep)
    contributions = problem.jacobian * np.where(keep, p, 0.0)[None, :]
    residual = problem.y - contributions.sum(axis=1)
    chi2 = float(np.sum((residual.real / sigma_total) ** 2 + (residual.imag / sigma_total) ** 2))
    dof = 2 * len(problem.y) - int(keep.sum())
    birge = chi2 / dof if dof > 0 else float("nan")
    if dof > 0 and birge > 1.0:
        cov = cov * birge
    cov = cov + _systematic_covariance(problem, p, keep, sigma_total)
    return FitResult(names=list(problem.names), estimate=p, covariance=cov, identifiable=keep,
                     chi2=chi2, dof=dof, birge_ratio=birge, singular_values_rel=s_rel,
                     weak_directions=weak, condition_number=condition, residual=residual,
                     sigma_total=sigma_total, fitted_contributions=contributions)
