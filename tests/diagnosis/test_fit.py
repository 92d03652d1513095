"""The weighted least squares, its covariance and identifiability, on synthetic linear problems."""

import numpy as np
import pytest

from hil.diagnosis.fit import LinearProblem, fit


def _problem(jacobian, p_true, sigma, rng, model_rel=None):
    noise = rng.normal(0, sigma, jacobian.shape[0]) + 1j * rng.normal(0, sigma, jacobian.shape[0])
    y = jacobian @ p_true + noise
    rel = np.zeros(jacobian.shape) if model_rel is None else model_rel
    return LinearProblem(names=[f"p{j}" for j in range(jacobian.shape[1])], y=y,
                         sigma=np.full(jacobian.shape[0], sigma), jacobian=jacobian,
                         model_rel=rel)


def test_estimates_and_uncertainties_are_statistically_right():
    """Over many noisy repetitions, |error| ≤ 2u about 95 % of the time, and χ²/ν ≈ 1."""
    rng = np.random.default_rng(0)
    jacobian = rng.normal(size=(40, 3)) + 1j * rng.normal(size=(40, 3))
    p_true = np.array([0.3, -1.2, 2.0])
    covered, birge = [], []
    for _ in range(400):
        result = fit(_problem(jacobian, p_true, 0.05, rng))
        u = result.standard_uncertainty()
        covered.append(np.abs(result.estimate - p_true) <= 2 * u)
        birge.append(result.birge_ratio)
    coverage = np.mean(covered, axis=0)
    assert np.all((coverage > 0.90) & (coverage < 0.99)), coverage
    assert np.median(birge) == pytest.approx(1.0, abs=0.1)


def test_collinear_parameters_are_reported_with_their_combination():
    rng = np.random.default_rng(1)
    base = rng.normal(size=(30, 1)) + 1j * rng.normal(size=(30, 1))
    other = rng.normal(size=(30, 1)) + 1j * rng.normal(size=(30, 1))
    jacobian = np.hstack([base, 2.0 * base, other])        # p0 and p1 act identically
    result = fit(_problem(jacobian, np.array([1.0, 0.5, 0.2]), 0.01, rng))
    assert list(result.identifiable) == [False, False, True]
    combination = result.weak_directions[0]["combination"]
    assert set(combination) == {"p0", "p1"}
    assert np.isnan(result.estimate[0]) and np.isnan(result.estimate[1])
    assert result.estimate[2] == pytest.approx(0.2, abs=5 * result.standard_uncertainty()[2])


def test_a_parameter_with_no_observation_is_not_identifiable():
    rng = np.random.default_rng(2)
    jacobian = np.hstack([rng.normal(size=(10, 1)) + 0j, np.zeros((10, 1))])
    result = fit(_problem(jacobian, np.array([1.0, 0.0]), 0.01, rng))
    assert list(result.identifiable) == [True, False]
    assert any("no observation" in w.get("reason", "") for w in result.weak_directions)


def test_a_wrong_model_inflates_the_uncertainty_by_the_birge_ratio():
    rng = np.random.default_rng(3)
    jacobian = rng.normal(size=(40, 1)) + 1j * rng.normal(size=(40, 1))
    problem = _problem(jacobian, np.array([1.0]), 0.01, rng)
    problem.y = problem.y + 0.2 * rng.normal(size=40)          # unmodelled content
    result = fit(problem)
    assert result.birge_ratio > 10
    plain = np.sqrt(1.0 / np.sum(np.abs(jacobian[:, 0]) ** 2 / 0.01 ** 2))
    assert result.standard_uncertainty()[0] == pytest.approx(plain * np.sqrt(result.birge_ratio),
                                                             rel=1e-6)


def test_a_stated_model_uncertainty_is_common_to_all_points():
    """A 10 % model error of a source cannot be averaged away by many points: the half of it taken
    as common to all points stays, u ≥ √½·10 %·p (scale part, times √2 for scale and phase)."""
    rng = np.random.default_rng(5)
    jacobian = rng.normal(size=(200, 1)) + 1j * rng.normal(size=(200, 1))
    problem = _problem(jacobian, np.array([2.0]), 1e-4, rng, model_rel=np.full((200, 1), 0.1))
    result = fit(problem)
    assert result.standard_uncertainty()[0] >= 0.5 * 0.1 * 2.0 * 0.99
    assert result.standard_uncertainty()[0] < 0.2


def test_a_bounded_term_widens_the_covariance_by_its_propagated_variance_only():
    """A SystematicTerm acting exactly like parameter 0's signature with standard uncertainty u
    adds u² to var(p0) (common to all rows: the estimator passes it on whole) and leaves the
    estimates and the weights alone; one acting like neither parameter adds nothing."""
    from hil.diagnosis.fit import SystematicTerm
    rng = np.random.default_rng(5)
    jacobian = rng.normal(size=(24, 2)) + 1j * rng.normal(size=(24, 2))
    problem = _problem(jacobian, np.array([0.4, -0.7]), 0.02, rng)
    plain = fit(problem)
    problem.rows = [(i // 3, i % 3 + 1) for i in range(24)]
    problem.systematic = [SystematicTerm("like_p0", jacobian[:, 0].copy(), 0.05)]
    widened = fit(problem)
    assert np.allclose(widened.estimate, plain.estimate)
    added = widened.covariance - plain.covariance
    assert added[0, 0] == pytest.approx(0.05 ** 2, rel=1e-9)
    assert abs(added[1, 1]) < 1e-12 and abs(added[0, 1]) < 1e-12
    split = SystematicTerm("like_p0_half_independent", jacobian[:, 0].copy(), 0.05, common=False)
    problem.systematic = [split]
    partial = fit(problem).covariance - plain.covariance
    assert 0 < partial[0, 0] < added[0, 0]
