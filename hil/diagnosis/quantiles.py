"""The two distribution quantiles the diagnosis judges with, from ``scipy.special``.

``scipy.stats`` costs seconds to import (it builds every distribution's docstring) and a
``hil run`` would pay that inside its diagnosis plan for two functions; these are the formulas
scipy.stats itself evaluates (``chi2_gen._ppf``, ``_norm_ppf`` in scipy 1.17), so the limits are
the same numbers bit for bit (tests/diagnosis/test_quantiles.py checks them against scipy.stats).
"""

from __future__ import annotations

from scipy import special


def chi2_ppf(q: float, dof: float) -> float:
    """Quantile ``q`` of the χ² distribution with ``dof`` degrees of freedom."""
    return float(2.0 * special.gammaincinv(dof / 2.0, q))


def norm_ppf(q: float) -> float:
    """Quantile ``q`` of the standard normal distribution."""
    return float(special.ndtri(q))
