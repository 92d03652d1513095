"""Between-capture reproducibility of order coefficients, from repeated base captures.

A spectrum's type A (``OrderSpectrum.sigma_nm``) is the revolution-to-revolution scatter inside
one capture. Part of a drive's ripple is fixed within a capture but not between captures: where
the PWM carrier and the encoder counts sit against the rotor when the capture starts, at a speed
whose PWM periods per electrical revolution are whole (20 kHz at 1000 rpm on an 8-pole motor:
300), locks the current loop's quantisation pattern for the whole capture. On the twin the
order-6 coefficient of the same base point moved by 0.1–0.35 mN·m from capture to capture
against a type-A σ of 0.04–0.07 mN·m (8-pole 48 V motor, 1000 rpm, 20 A), so a standard
addition's transfer and its estimate of the dead time moved by several of their stated
uncertainties with what the bench did before (``studies/results/validity_deviations.md``).

The same point captured twice (or more) measures it: per mechanical order m, the pooled
variance of the repeated captures' coefficients (each of Re and Im) less their type-A variance
is the reproducibility variance s_R²(m) (ISO 5725-3: an intermediate precision with one
factor, the capture). Every capture then carries σ² = σ_A² + s_R² at that order.

Limits (review h-17): the expanded uncertainties keep k = 2 although s_R comes from few degrees
of freedom (8 in the plan; a simulation of the plan's layout covered 91 % at a nominal 95 %);
a drift between the first and the repeated captures (the repeat comes after the additions)
reads as scatter here, shown with its sign in ``last_less_first_nm`` but not tested; the
factorial fit (``hil.diagnosis.fit``) does not carry s_R (it rescales by its own Birge ratio).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from hil.diagnosis.orders import OrderSpectrum


@dataclass(frozen=True)
class Reproducibility:
    """s_R (N·m, per component) at each order estimated, with its degrees of freedom and the
    pooled scatter and type A it came from."""

    sigma_nm: dict            # mech order -> s_R (0 where the scatter is within type A)
    scatter_nm: dict          # mech order -> pooled σ of the repeated captures, per component
    type_a_nm: dict           # mech order -> rms of their type-A σ
    dof: int                  # real degrees of freedom of each order's pooled scatter
    points: list              # labels of the points captured more than once
    #: mech order -> per point, the last capture less the first (N·m, complex): a drift between
    #: them (a winding warming through the additions) reads as scatter in s_R; here it shows
    #: with its sign, for the reader to see (not tested)
    change_nm: dict | None = None

    def to_dict(self) -> dict:
        return {"method": "repeated base captures at the same point: pooled variance of the "
                          "coefficients less their type A (ISO 5725-3, one factor: the capture)",
                "points": list(self.points), "dof": self.dof,
                "orders": {str(m): {"s_R_nm": self.sigma_nm[m], "scatter_nm": self.scatter_nm[m],
                                    "type_a_nm": self.type_a_nm[m],
                                    "last_less_first_nm": [
                                        {"point": label, "re": value.real, "im": value.imag}
                                        for label, value in (self.change_nm or {}).get(m, [])]}
                           for m in sorted(self.sigma_nm)}}


def estimate(groups: list[tuple[str, list[OrderSpectrum]]], orders) -> Reproducibility | None:
    """s_R at each of ``orders`` from ``groups`` of (label, spectra of the same point with
    nothing changed between them); None when no group has two spectra."""
    repeated = [(label, spectra) for label, spectra in groups if len(spectra) >= 2]
    if not repeated:
        return None
    sigma, scatter, type_a, change = {}, {}, {}, {}
    dof = 2 * sum(len(spectra) - 1 for _, spectra in repeated)
    for m in orders:
        squares, variances = 0.0, []
        for _, spectra in repeated:
            values = np.array([s.coefficients_nm[m] for s in spectra])
            squares += float(np.sum(np.abs(values - values.mean()) ** 2))
            variances += [float(s.sigma_nm[m]) ** 2 for s in spectra]
        pooled = squares / dof                        # per component (Re and Im pooled)
        within = float(np.mean(variances))
        sigma[m] = float(np.sqrt(max(pooled - within, 0.0)))
        scatter[m], type_a[m] = float(np.sqrt(pooled)), float(np.sqrt(within))
        change[m] = [(label, complex(spectra[-1].coefficients_nm[m]
                                     - spectra[0].coefficients_nm[m]))
                     for label, spectra in repeated]
    return Reproducibility(sigma, scatter, type_a, dof, [label for label, _ in repeated], change)


def applied(spectrum: OrderSpectrum, reproducibility: Reproducibility | None) -> OrderSpectrum:
    """``spectrum`` whose σ at each estimated order includes s_R in quadrature."""
    if reproducibility is None:
        return spectrum
    sigma = np.array(spectrum.sigma_nm, dtype=float, copy=True)
    for m, s_r in reproducibility.sigma_nm.items():
        if m < sigma.size:
            sigma[m] = float(np.hypot(sigma[m], s_r))
    return replace(spectrum, sigma_nm=sigma)
