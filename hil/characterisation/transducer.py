"""The torque transducer's response as it runs on the bench: its first-order bandwidth from the
captures of the loop test signal (issue 29 Build 2; ``hil.characterisation.loop``).

In each loop capture the drive adds A·sin(k·θe) to its q-current reference, so i_q and with it
the air-gap torque T = K_t·i_q (surface PMSM, the paper's eq. 1) carry order k, at
f_k = k·f_e. The DAQ reads i_q (ia_a, ib_a and the angle channel) and the transducer's reading
``torque_nm`` of that torque. Per electrical revolution, the ratio of the order-k phasors
T_k/Q_k divided by the same ratio at dc (the mean torque over the mean i_q, in the same
capture) is the transducer's response H(f_k): K_t and the transducer's own scale cancel (a
transducer reading 5 % high is the self-check's finding, not a bandwidth). Its magnitude is
fitted with the first-order low-pass the bench file states (``[torque] bandwidth_hz``),
|H(f)| = 1/√(1 + (f/f_c)²), by weighted least squares (weights: the revolution-to-revolution
scatter). The phase is not used: the DAQ's channel skew and any transport lag enter it (the
self-check judges the transducer's phase).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import least_squares

from hil.capture import Capture
from hil.characterisation.identify import (Identified, electrical_angle_abs,
                                           phasors_per_revolution, speed_rad_s)
from hil.characterisation.loop import dq_current

#: Relative standard uncertainty of the first-order model's fit (type B): the largest |error| of
#: the fitted bandwidth against the simulated transducer's truth over the coverage study's
#: calibration drives (seed 0, 10 drives: −0.046 %…−0.002 %, the discrete simulated filter),
#: held out on seed 1 (studies/results/characterisation_coverage.md). A real transducer that is
#: not first-order shows in the fit's χ², which scales the type-A part.
MODEL_U_PU = 0.0005
#: A bandwidth whose U (k = 2) is this share of its value or more confirms nothing (the test
#: frequencies lie far below it): "not identified", the stated one is used.
RESOLVABLE_U_PU = 0.3


def response_magnitude(capture: Capture, pole_pairs: int, order: int
                       ) -> tuple[float, float, float]:
    """(f_k in Hz, |H(f_k)|, its type-A standard uncertainty) from one loop capture."""
    theta = electrical_angle_abs(capture, pole_pairs)
    _, iq = dq_current(capture, theta)
    torque = np.asarray(capture["torque_nm"], dtype=float)
    dc_nm_per_a = float(torque.mean() / iq.mean())
    ratio = np.abs(phasors_per_revolution(torque, theta, order)
                   / phasors_per_revolution(iq, theta, order)) / abs(dc_nm_per_a)
    frequency_hz = order * abs(speed_rad_s(capture)) * pole_pairs / (2.0 * math.pi)
    return frequency_hz, float(ratio.mean()), float(np.std(ratio, ddof=1) / math.sqrt(ratio.size))


def first_order_magnitude(frequency_hz, bandwidth_hz):
    """|H| of a first-order low-pass of ``bandwidth_hz`` (−3 dB) at ``frequency_hz``."""
    return 1.0 / np.sqrt(1.0 + (np.asarray(frequency_hz) / bandwidth_hz) ** 2)


def fit_bandwidth(points, stated_hz: float) -> Identified | str:
    """The transducer's bandwidth (Identified, ``[torque] bandwidth_hz``) from ``points``
    [(f_k Hz, |H|, u)], or the reason it is not identified."""
    frequencies = np.array([f for f, _, _ in points])
    measured = np.array([h for _, h, _ in points])
    weights = np.array([max(u, 1e-6) for _, _, u in points])

    def residual(x):
        return (first_order_magnitude(frequencies, x[0]) - measured) / weights

    fit = least_squares(residual, [stated_hz], bounds=([1.0], [1e6]), x_scale=[stated_hz])
    dof = max(len(points) - 1, 1)
    chi2 = float(np.sum(fit.fun ** 2)) / dof
    value = float(fit.x[0])
    u = math.hypot(math.sqrt(np.linalg.pinv(fit.jac.T @ fit.jac)[0, 0] * max(1.0, chi2)),
                   MODEL_U_PU * value)
    listed = ", ".join(f"{f:.0f} Hz: {h:.3f}" for f, h, _ in points)
    if not math.isfinite(u) or 2.0 * u >= RESOLVABLE_U_PU * value:
        return (f"the loop test signal's frequencies ({listed}) do not pin the transducer's "
                f"bandwidth down: {value:.4g} ± {2.0 * u:.3g} Hz (k = 2)")
    method = (f"the loop test signal's torque over its i_q at each test order, per unit of the "
              f"same ratio at dc (|H|: {listed}); a first-order low-pass fitted by weighted least "
              f"squares (χ²/dof {chi2:.2g}), with the model's type-B u {MODEL_U_PU:.2%}")
    return Identified("bandwidth_hz", value, u, "Hz", method)
