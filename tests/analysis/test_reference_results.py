"""The analysis chain gives the results frozen before its speed work, to 1e-12 relative.

``reference_results.npz`` was written by ``reference_cases.py`` with the chain as it was before
issue 17 item 5 (numpy unwrap/searchsorted/histogram). Each figure must match to 1e-12 of its own
magnitude; an array is compared element by element to 1e-12 relative, with an absolute floor of
1e-12 of the array's largest magnitude (a phase of an order at the noise floor, or a bias near zero,
is judged against the scale of its array). NaN must stay NaN.

The uncertainty budget's figures (``BUDGET_FIELDS``) come from the type-A bootstrap, whose draws
are evaluated in single precision since issue 33 (``peak_to_peak(single_precision=True)``): they
match to ``BOOTSTRAP_RTOL`` = 1e-5 of their own magnitude or ``BOOTSTRAP_ATOL_PU`` = 1e-8 pu
(measured: ≤ 2.7e-6 relative on the standard uncertainties; 7.6e-10 pu on a SIMEX bias of
1.06e-5 pu, a small difference of means), far below the ~3.5 % (1/√(2·400)) Monte Carlo scatter
of the bootstrap's 400 draws themselves.
"""

from __future__ import annotations

import numpy as np
import pytest

from reference_cases import BUDGET_FIELDS, CASES, REFERENCE_PATH, figures

RTOL = 1e-12
BOOTSTRAP_RTOL = 1e-5
BOOTSTRAP_ATOL_PU = 1e-8


@pytest.fixture(scope="module")
def reference():
    with np.load(REFERENCE_PATH) as stored:
        return {name: stored[name] for name in stored.files}


@pytest.mark.parametrize("case", sorted(CASES))
def test_results_match_the_frozen_reference(case, reference):
    actual = figures(CASES[case]())
    expected_names = {name.split("/", 1)[1] for name in reference if name.startswith(case + "/")}
    assert set(actual) == expected_names
    for name, values in actual.items():
        expected = reference[f"{case}/{name}"]
        assert values.shape == expected.shape, name
        scale = float(np.nanmax(np.abs(expected))) if np.isfinite(expected).any() else 0.0
        rtol, atol = ((BOOTSTRAP_RTOL, BOOTSTRAP_ATOL_PU) if name in BUDGET_FIELDS
                      else (RTOL, RTOL * scale))
        np.testing.assert_allclose(values, expected, rtol=rtol, atol=atol,
                                   equal_nan=True, err_msg=f"{case}: {name}")
