"""The diagnosis's χ² and normal quantiles (hil/diagnosis/quantiles.py, from scipy.special so
that a run need not import scipy.stats) are scipy.stats's own numbers, bit for bit."""

import pytest
from scipy import stats

from hil.diagnosis.quantiles import chi2_ppf, norm_ppf


@pytest.mark.parametrize("q", [0.5, 0.95, 0.99, 0.999, 0.9999])
@pytest.mark.parametrize("dof", [1, 2, 3, 7, 40, 233])
def test_chi2_quantile_is_scipy_stats(q, dof):
    assert chi2_ppf(q, dof) == float(stats.chi2.ppf(q, dof))


@pytest.mark.parametrize("q", [0.5, 0.9, 0.975, 0.9995, 0.99999])
def test_normal_quantile_is_scipy_stats(q):
    assert norm_ppf(q) == float(stats.norm.ppf(q))
