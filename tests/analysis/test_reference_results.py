"""The analysis chain gives the results frozen before its speed work, to 1e-12 relative.

``reference_results.npz`` was written by ``reference_cases.py`` with the chain as it was before
issue 17 item 5 (numpy unwrap/searchsorted/histogram). Each figure must match to 1e-12 of its own
magnitude; an array is compared element by element to 1e-12 relative, with an absolute floor of
1e-12 of the array's largest magnitude (a phase of an order at the noise floor, or a bias near zero,
is judged against the scale of its array). NaN must stay NaN.
"""

from __future__ import annotations

import numpy as np
import pytest

from reference_cases import CASES, REFERENCE_PATH, figures

RTOL = 1e-12


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
        np.testing.assert_allclose(values, expected, rtol=RTOL, atol=RTOL * scale,
                                   equal_nan=True, err_msg=f"{case}: {name}")
