"""Fleet statistics honest at small n (issue 32 item 5):

* ``hil yield --from-db``'s predicted yield carries the fit's own uncertainty from n units (a
  Bayesian prediction interval): it narrows with n, covers the simulated truth, and is not
  stated below 6 units (reduced from ``studies/fleet_yield_small_n.py``);
* ``hil trend`` states neither control limits nor Cpk from too few runs, and no negative lower
  control limit for a pk-pk;
* the ``hil compare`` plot lists, and does not plot, a point off the scale of a torque ripple.
"""

from __future__ import annotations

import numpy as np
import pytest

from hil.results.capability import capability, control_chart
from hil.results.fleet_interval import predicted_yield, spec_yield
from hil.results.fleet_yield import fitted_spec
from hil.tolerance.spec import parse_tolerances

SPEC = {"drives": 4000, "seed": 3,
        "requirement": {"id": "REQ-12", "name": "pk-pk at most 3 %", "quantity": "pk_pk_pct",
                        "limit": {"max": 3.0}},
        "operating_point": [{"speed_rpm": 500, "current_a": 20, "current_angle_deg": 0}],
        "parameters": {"ia_offset_a": {"distribution": "normal", "sigma": 0.5}}}
TRUE_MEAN, TRUE_SIGMA, U = 0.05, 0.25, 0.03


def _fit(estimates: np.ndarray) -> dict:
    """``fit_parameters``' entry for these estimates (its formulas: mean, s, σ)."""
    n, s = len(estimates), float(np.std(estimates, ddof=1))
    return {"ia_offset_a": {"units": n, "mean": float(np.mean(estimates)), "s": s,
                            "mean_u": U, "sigma": float(np.sqrt(max(s * s - U * U, 0.0)))}}


def _fleet(rng, n):
    return rng.normal(TRUE_MEAN, TRUE_SIGMA, n) + rng.normal(0.0, U, n)


def test_the_predicted_yield_interval_narrows_with_n_and_covers_the_truth():
    spec = parse_tolerances(SPEC)
    truth = spec_yield(fitted_spec(spec, {"ia_offset_a": {"mean": TRUE_MEAN,
                                                          "sigma": TRUE_SIGMA}}),
                       np.random.default_rng(1), 100_000)
    assert 0.3 < truth < 0.95                 # a yield the interval can miss on either side
    rng = np.random.default_rng(7)
    kwargs = {"draws": 100, "drives_per_draw": 1000}
    widths = {}
    for n in (3, 10, 100):
        p = predicted_yield(spec, _fit(_fleet(rng, n)), seed=n, **kwargs)
        widths[n] = p["interval95"][1] - p["interval95"][0]
        assert p["stated"] is (n >= 6)
    assert widths[3] > widths[10] > widths[100]
    covered = sum(low <= truth <= high for low, high in
                  (predicted_yield(spec, _fit(_fleet(rng, 10)), seed=k, **kwargs)["interval95"]
                   for k in range(10)))
    assert covered >= 8                       # 95 % nominal: P(≥ 8 of 10) ≈ 0.99


def test_a_point_estimate_interval_would_not_cover():
    """The defect this catches: the old interval (Monte Carlo error of the fitted values) at
    n = 10 is far narrower than the spread of yields the fit allows."""
    spec = parse_tolerances(SPEC)
    p = predicted_yield(spec, _fit(_fleet(np.random.default_rng(3), 10)), draws=80,
                        drives_per_draw=1000)
    monte_carlo_only = 2 * 1.96 * np.sqrt(0.25 / 4000)        # ≤ ±1.5 % at 4000 drives
    assert p["interval95"][1] - p["interval95"][0] > 4 * monte_carlo_only


def test_too_few_runs_state_no_control_limits_nor_cpk():
    few = [0.007, 0.0071, 0.0069]
    chart, cap = control_chart(few, nonnegative=True), capability(few, None, 0.03)
    assert not chart["stated"] and "too few" in chart["reason"]
    assert not cap["stated"] and "too few" in cap["reason"]
    many = list(np.random.default_rng(0).normal(0.007, 0.0002, 25))
    assert control_chart(many)["stated"] and capability(many, None, 0.03)["stated"]


def test_no_negative_lower_control_limit_for_a_pk_pk():
    values = list(np.abs(np.random.default_rng(2).normal(0.0, 0.002, 25)))
    chart = control_chart(values, nonnegative=True)
    assert chart["lcl"] is None and "below 0" in chart["lcl_note"]
    assert control_chart(values)["lcl"] < 0          # a signed quantity keeps it


def test_the_compare_plot_lists_a_point_off_the_torque_scale(tmp_path, monkeypatch):
    from hil.results import plots

    drawn = []
    point = lambda name, d, u: {"test_id": f"t.py::{name}",  # noqa: E731
                                "pk_pk_pu": {"difference": d, "u_difference": u,
                                             "changed": abs(d) > u}}
    result = {"run_a": "A", "run_b": "B",
              "points": [point("baseline", 0.002, 0.001), point("angle_reference", 3.0, 1e5)]}
    plt = plots._pyplot()
    original = plt.Axes.errorbar
    monkeypatch.setattr(plt.Axes, "errorbar",
                        lambda self, x, y, **kw: (drawn.append((x, y)),
                                                  original(self, x, y, **kw))[1])
    texts = []
    original_text = plt.Figure.text
    monkeypatch.setattr(plt.Figure, "text",
                        lambda self, x, y, s, **kw: (texts.append(s),
                                                     original_text(self, x, y, s, **kw))[1])
    plots.compare_plot(result, tmp_path / "cmp.png")
    assert drawn == [(pytest.approx(0.2), 0)]          # only the baseline is plotted
    assert any("angle_reference" in t and "not plotted" in t for t in texts)
