"""The current loop as it runs on the bench: its gain relative to the documented design and its
delay, from the drive's own test signal (issue 29; EDS 0x200C/0x200D ``loop_test_amplitude_a``,
``loop_test_order``: i_q* = I·cos φ + A·sin(k·θe)).

Per test order k the response H_k = Q_k/(−j·A) (Q_k the order-k phasor of the measured i_q, the
DAQ's phase currents Park-transformed with the angle channel, which reads the drive's encoder:
both frames lag the rotor by the same truncated count) is compared with the documented
design run on the *measured* motor, sampled at the PWM rate (``model_response``): a PI with
Kp = g·ωc·L0, Ki = g·ωc·R0 (ωc the documented bandwidth, R0, L0 the ``[motor]`` the drive was
configured from; the "continuous" design), a computation delay and the measured R, L. In the
rotor frame T = L/(1 + L), and a real q-axis sine at ω = k·ωe gives H = (T(ω) + conj T(−ω))/2.
g is fitted to the magnitudes |H_k| by weighted least squares (weights: the revolution-to-
revolution scatter), the delay held at the documented one; u from the Jacobian (scaled by the
residual when it exceeds the scatter) and the measured L's u propagated. g = 1 is the documented
loop; the bench's loop bandwidth is g·ωc. The phases are not used: at one speed an offset δ
between the drive's angle and the DAQ's angle channel turns order k by k·δ, indistinguishable
from a delay (on the simulated bench the two frames differ by ≈ 0.4 of an encoder count,
0.04 rad at order 48, unexplained here), so the delay is not identified (two speeds would
separate them).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import least_squares

from hil.capture import Capture
from hil.characterisation.identify import Identified, electrical_angle_abs, phasors_per_revolution


def q_current(capture: Capture, theta: np.ndarray) -> np.ndarray:
    """i_q (A) from the DAQ's ia, ib (ic = −ia − ib), q along the EMF (e_a = E·sin θe)."""
    ia = np.asarray(capture["ia_a"], dtype=float)
    ib = np.asarray(capture["ib_a"], dtype=float)
    ic = -ia - ib
    return 2.0 / 3.0 * (ia * np.sin(theta) + ib * np.sin(theta - 2 * math.pi / 3)
                        + ic * np.sin(theta + 2 * math.pi / 3))


def response(capture: Capture, pole_pairs: int, order: int, amplitude_a: float
             ) -> tuple[complex, float]:
    """(H_k, its type-A u per component) from one capture with the test signal at ``order``."""
    theta = electrical_angle_abs(capture, pole_pairs)
    iq = q_current(capture, theta)
    values = phasors_per_revolution(iq, theta, order) / (-1j * amplitude_a)
    n = values.size
    u = math.hypot(np.std(values.real, ddof=1), np.std(values.imag, ddof=1)) / math.sqrt(2 * n)
    return complex(values.mean()), float(u)


def model_response(omega, omega_e, gain, delay_periods, bandwidth_rad_s, tuned, plant,
                   pwm_hz):
    """H at rotor-frame frequency ``omega`` (rad/s) of the sampled loop: the documented PI × g
    (forward-Euler integrator, Kp = g·ωc·L0, Ki = g·ωc·R0), its output applied ``delay_periods``
    later and held over a PWM period (a vector fixed in the stator frame, turning at −ωe in the
    rotor frame), the plant sampled at the period boundaries: i[n+1] = a·i[n] + b·v[n],
    a = e^{−(R/L + jωe)·T}, b = e^{−jωe·T}·(1 − e^{−R·T/L})/R (exact for that held vector)."""
    period = 1.0 / pwm_hz
    resistance, inductance = plant
    a = np.exp(-(resistance / inductance + 1j * omega_e) * period)
    b = np.exp(-1j * omega_e * period) * -np.expm1(-resistance * period / inductance) / resistance
    kp = gain * bandwidth_rad_s * tuned[1]
    ki_t = gain * bandwidth_rad_s * tuned[0] * period

    def closed(w):
        z = np.exp(1j * w * period)
        loop = (kp + ki_t / (z - 1.0)) * z ** -delay_periods \
            * np.exp(-1j * omega_e * delay_periods * period) * b / (z - a)
        return loop / (1.0 + loop)
    return 0.5 * (closed(omega) + np.conj(closed(-omega)))


#: Relative standard uncertainty of the sampled-loop model's |H| (type B): the largest mismatch
#: between ``model_response`` and the simulated firmware at its own design point (Table I, 1.6 kHz,
#: 500 rpm, orders 24/48/96 at 100 kHz sampling: 0.8 %, 1.1 %, 0.05 %), held out: the coverage
#: study's random drives (studies/results/characterisation_coverage.md).
MODEL_U_PU = 0.011


def fit_loop(points, omega_e, bandwidth_hz, delay_guess_s, tuned, plant, u_inductance,
             pwm_hz):
    """The gain g (Identified) from the magnitudes |H_k| of ``points`` [(order, H, u)], the delay
    held at the documented ``delay_guess_s`` = (computation delay + ½)/f_pwm."""
    omegas = np.array([order * omega_e for order, _, _ in points], dtype=float)
    measured = np.array([h for _, h, _ in points])
    weights = np.array([math.hypot(u, MODEL_U_PU * abs(h)) for _, h, u in points])
    bandwidth = 2 * math.pi * bandwidth_hz

    delay_periods = max(delay_guess_s * pwm_hz - 0.5, 0.0)

    def residual(x, plant_=plant):
        model = model_response(omegas, omega_e, x[0], delay_periods, bandwidth, tuned, plant_,
                               pwm_hz)
        return (np.abs(model) - np.abs(measured)) / weights

    fit = least_squares(residual, [1.0], bounds=([0.05], [5.0]))
    dof = max(len(points) - 1, 1)
    chi2 = float(np.sum(fit.fun ** 2)) / dof
    cov = np.linalg.pinv(fit.jac.T @ fit.jac) * max(1.0, chi2)
    u_gain = math.sqrt(cov[0, 0])
    # the measured L's u: refit with L + u_L
    shifted = least_squares(lambda x: residual(x, (plant[0], plant[1] + u_inductance)),
                            fit.x, bounds=([0.05], [5.0])).x
    u_gain = math.hypot(u_gain, shifted[0] - fit.x[0])
    orders = ", ".join(str(order) for order, _, _ in points)
    method = (f"the drive's loop test signal (0x200C/0x200D: A·sin(k·θe) on i_q*) at electrical "
              f"orders {orders}; i_q from ia_a, ib_a and the angle channel; the documented "
              f"design (PI Kp = g·ωc·L0, Ki = g·ωc·R0, ωc = 2π·{bandwidth_hz:g} Hz, sampled at "
              f"{pwm_hz:g} Hz) with a delay on the measured R, L, fitted by weighted least "
              f"squares (χ²/dof {chi2:.2g})")
    gain = Identified("current_loop_gain_pu", float(fit.x[0]), u_gain, "1",
                      method + "; g = 1 is the documented loop")
    return gain
