"""The current loop as it runs on the bench: its gain g relative to the documented design, from
the drive's own test signal (issue 29; EDS 0x200C/0x200D ``loop_test_amplitude_a``,
``loop_test_order``: i_q* = I·cos φ + A·sin(k·θe)).

Response (``response``): per test order k, H_k = Q_k/(−j·A), Q_k the order-k phasor of i_q, the
DAQ's phase currents Park-transformed in the drive's own frame (the angle channel turned to
where the drive holds its mean current, per capture: ``drive_frame_rad``).

Model (``model_response``): the documented "continuous" design on the measured motor, as the
firmware runs it —

* the PI Kp = g·ωc·L0, Ki = g·ωc·R0 (ωc the documented bandwidth; R0, L0 the ``[motor]`` the
  drive was configured from) at the PWM rate, the present error in the integrator:
  C(z) = Kp + Ki·Ts·z/(z − 1) (``pi_controller``);
* its output applied d periods later, at the angle it was computed for, for one PWM period;
* the loop closes on the current at its sampling instants (``sampled_plant``, exact), while the
  DAQ sees the continuous current's fundamental: the period's centred PWM pulses
  (``pulse_hold``) through the winding 1/(R + jΩL), Ω the stator-frame frequency
  (``held_plant``);
* a real q-axis sine at ω = k·ωe: H = (T(ω) + conj T(−ω))/2; the encoder's truncation:
  ``angle_quantisation``.

Fit (``fit_loop``): g and a frame offset δ common to the captures (order k turned by k·δ) to the
complex H_k by weighted least squares (weights: the revolution-to-revolution scatter, the
model's type-B u and the truncation's); u from the Jacobian (scaled by the residual where
χ²/dof > 1) and the measured L's u propagated. g = 1 is the documented loop; the bench's loop
bandwidth is g·ωc. The phases carry most of the information: at a fast loop |H_k| at up to
1 × ωc passes through a maximum near the true g, while the phase lag falls monotonically with g.
The delay is held at the documented one, not identified (at one speed it trades against g); a
delay other than the documented one shows as χ²/dof ≫ 1.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from hil.capture import Capture
from hil.characterisation.identify import (Identified, electrical_angle_abs, fit_per_revolution,
                                           phasors_per_revolution)


def dq_current(capture: Capture, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(i_d, i_q) in A from the DAQ's ia, ib (ic = −ia − ib) in the frame of θ, q along
    sin θ (a current i_a = I·sin(θ + γ) gives i_q = I·cos γ, i_d = I·sin γ)."""
    ia = np.asarray(capture["ia_a"], dtype=float)
    ib = np.asarray(capture["ib_a"], dtype=float)
    phases = (ia, ib, -ia - ib)
    shifts = (0.0, -2 * math.pi / 3, 2 * math.pi / 3)
    i_q = 2.0 / 3.0 * sum(i * np.sin(theta + shift) for i, shift in zip(phases, shifts))
    i_d = 2.0 / 3.0 * sum(i * np.cos(theta + shift) for i, shift in zip(phases, shifts))
    return i_d, i_q


def drive_frame_rad(capture: Capture, theta: np.ndarray, current_angle_rad: float,
                    order: int) -> tuple[float, float]:
    """(γ_d, its type-A u) in rad (electrical): the angle to add to θ to reach the drive's own
    frame. The drive holds its mean current at i_d = −I·sin φ, i_q = I·cos φ
    (φ = ``current_angle_rad``) in its frame, so its frame is where the measured mean current
    sits, atan2(ī_d, ī_q), turned back by −φ; the means fitted per revolution beside the test
    signal at ``order``, u from their scatter. Per capture: at a speed where a PWM period holds a
    whole number of encoder counts the drive's truncated angle lags the rotor by a fixed fraction
    of a count that differs from capture to capture (order k turned by k times it: up to
    0.04 rad at order 24 of the shipped bench)."""
    i_d, i_q = (fit_per_revolution(part, theta, order)[1] for part in dq_current(capture, theta))
    angles = np.arctan2(i_d, i_q) + current_angle_rad
    return float(angles.mean()), float(np.std(angles, ddof=1) / math.sqrt(angles.size))


def response(capture: Capture, pole_pairs: int, order: int, amplitude_a: float,
             current_angle_rad: float = 0.0) -> tuple[complex, float]:
    """(H_k, its type-A u per component) from one capture with the test signal at ``order``, in
    the drive's own frame (``drive_frame_rad``; its u turns H_k by k·u: added in quadrature)."""
    theta = electrical_angle_abs(capture, pole_pairs)
    frame, u_frame = drive_frame_rad(capture, theta, current_angle_rad, order)
    theta = theta + frame
    _, i_q = dq_current(capture, theta)
    values = phasors_per_revolution(i_q, theta, order) / (-1j * amplitude_a)
    n = values.size
    u = math.hypot(np.std(values.real, ddof=1), np.std(values.imag, ddof=1)) / math.sqrt(2 * n)
    return complex(values.mean()), math.hypot(u, order * u_frame * abs(values.mean()))


def angle_count_elec_rad(capture: Capture, pole_pairs: int) -> float:
    """Δ: the electrical angle (rad) of one count of the angle channel (its LSB in the capture's
    ``daq_lsb`` × pole pairs), 0 where the capture does not state it."""
    table = capture.meta.get("daq_lsb")
    lsb = table.get("rotor_angle_mech_rad") if isinstance(table, dict) else None
    return float(lsb) * pole_pairs if lsb else 0.0


@dataclass(frozen=True)
class LoopSetup:
    """What the loop model needs besides g and the plant: the loop as documented and the bench
    it runs on."""

    omega_e_rad_s: float                  # electrical speed, signed
    bandwidth_hz: float                   # documented bandwidth ωc/2π
    delay_s: float                        # documented loop delay, (computation + ½ period)
    tuned: tuple[float, float]            # (R0 in Ω, L0 in H) the gains were set from
    pwm_hz: float
    count_elec_rad: float = 0.0           # Δ: one count of the angle channel, electrical rad
    duties: tuple[float, ...] = (0.5,)    # the legs' duties through a revolution (``svpwm_duties``)

    @property
    def period_s(self) -> float:
        return 1.0 / self.pwm_hz

    @property
    def delay_periods(self) -> float:
        """d: the computation delay in PWM periods (the documented delay less the hold's ½)."""
        return max(self.delay_s * self.pwm_hz - 0.5, 0.0)


def phase_voltage_peak_v(current_a, current_angle_rad, omega_e_rad_s, emf_peak_v, plant):
    """|v| (V, peak phase) at the operating point: v = (R + jωe·L)·i + j·E in dq (d + jq),
    i = I·(−sin φ + j·cos φ), the EMF E on q."""
    resistance, inductance = plant
    current = current_a * complex(-math.sin(current_angle_rad), math.cos(current_angle_rad))
    return abs((resistance + 1j * omega_e_rad_s * inductance) * current + 1j * emf_peak_v)


def svpwm_duties(voltage_peak_v, dc_bus_v, points=120) -> tuple[float, ...]:
    """Duties of the three legs through a revolution: d = ½ + (v_x + z)/V_dc, v_x the phase
    voltages, z = −(max + min)/2 the min-max zero sequence (SVPWM; sine-triangle, z = 0, moves
    ``pulse_hold`` by ≤ 0.07 % at Ω = 2π·2 kHz, 20 kHz PWM, |v| up to 0.54·V_dc)."""
    theta = np.linspace(0.0, 2 * math.pi, points, endpoint=False)
    legs = np.array([voltage_peak_v * np.cos(theta - 2 * math.pi * x / 3) for x in range(3)])
    zero = -0.5 * (legs.max(axis=0) + legs.min(axis=0))
    return tuple(np.clip(0.5 + (legs + zero) / dc_bus_v, 0.0, 1.0).ravel())


def pi_controller(z, kp_v_per_a, ki_ts_v_per_a):
    """C(z) = Kp + Ki·Ts·z/(z − 1): the integrator adds the present error before the output
    (I[n] = I[n−1] + Ki·Ts·e[n], v[n] = Kp·e[n] + I[n]; ``hil.sim.firmware._pi_axis``)."""
    return kp_v_per_a + ki_ts_v_per_a * z / (z - 1.0)


def sampled_plant(z, omega_e, plant, period_s):
    """i[n+1] = a·i[n] + b·v[n] in the rotor frame: a = e^{−(R/L + jωe)·Ts}, b = e^{−jωe·Ts}·
    (1 − e^{−R·Ts/L})/R, exact for a voltage vector held fixed in the stator frame over a
    period (it turns at −ωe in the rotor frame); A/V."""
    resistance, inductance = plant
    a = np.exp(-(resistance / inductance + 1j * omega_e) * period_s)
    b = np.exp(-1j * omega_e * period_s) * -np.expm1(-resistance * period_s / inductance) \
        / resistance
    return b / (z - a)


def pulse_hold(stator_rad_s, period_s, duties):
    """The fundamental at stator frequency Ω of a period's centred PWM pulses per unit change of
    their mean: a duty change moves both edges, at Ts/2 ± d·Ts/2, so e^{−jΩTs/2}·⟨cos(Ω·d·Ts/2)⟩
    over the legs' duties (the held mean voltage would give e^{−jΩTs/2}·sinc(ΩTs/2); at d = ½
    the pulses' is (ΩTs)²/96 larger)."""
    stator = np.asarray(stator_rad_s, dtype=float)
    spread = np.cos(np.multiply.outer(stator, np.asarray(duties)) * period_s / 2).mean(axis=-1)
    return np.exp(-0.5j * stator * period_s) * spread


def held_plant(omega, setup: LoopSetup, plant):
    """The continuous current's fundamental at rotor-frame ω per volt of the voltage sequence
    (A/V): ``pulse_hold`` and the winding 1/(R + jΩL), Ω = ω + ωe in the stator frame
    (→ ``sampled_plant`` as ΩTs → 0)."""
    resistance, inductance = plant
    stator = omega + setup.omega_e_rad_s
    hold = pulse_hold(stator, setup.period_s, setup.duties)
    return hold / (resistance + 1j * stator * inductance)


def model_response(omega, gain, plant, setup: LoopSetup):
    """H at rotor-frame frequency ``omega`` (rad/s) of the continuous current for the sampled
    loop (module docstring): the documented PI × g (``pi_controller``, Kp = g·ωc·L0,
    Ki = g·ωc·R0 from ``setup.tuned``), its output applied d periods later (z^{−d}·e^{−jωe·d·Ts}:
    at the angle it was computed for) as PWM pulses; ``plant`` = (R in Ω, L in H).
    T = C·D·G/(1 + C·D·P), G = ``held_plant``, P = ``sampled_plant``."""
    period, omega_e, delay = setup.period_s, setup.omega_e_rad_s, setup.delay_periods
    bandwidth = 2 * math.pi * setup.bandwidth_hz
    kp = gain * bandwidth * setup.tuned[1]
    ki_ts = gain * bandwidth * setup.tuned[0] * period

    def closed(w):
        z = np.exp(1j * w * period)
        forward = pi_controller(z, kp, ki_ts) * z ** -delay * np.exp(-1j * omega_e * delay
                                                                      * period)
        return forward * held_plant(w, setup, plant) \
            / (1.0 + forward * sampled_plant(z, omega_e, plant, period))
    w = np.asarray(omega, dtype=float)
    return 0.5 * (closed(w) + np.conj(closed(-w)))


def angle_quantisation(orders, count_elec_rad):
    """(factor, its relative u) of order k from the truncated encoder counts: the DAQ's phasor
    on counts sampled at its own rate scales order k by s = sinc(k·Δ/2) (truncation error
    uniform over a count); the drive's test signal, from its own truncated angle at the PWM
    rate, by s too, or by 1 where a PWM period holds a whole number of counts (a fixed lag, in
    ``drive_frame_rad``): its midpoint (1 + s)/2, rectangular half-width (1 − s)/2."""
    s = np.sinc(np.asarray(orders, dtype=float) * count_elec_rad / (2 * math.pi))
    return s * (1.0 + s) / 2, (1.0 - s) / (1.0 + s) / math.sqrt(3.0)


#: Relative standard uncertainty (type B, per component) of the model's H_k: the RMS of
#: |H_k − model|/(√2·|H_k|) at the top test order over a calibration set, the model at the true
#: g, R, L (studies/loop_model_calibration.py: the coverage study's seed 0, 30 drives: 0.072 %,
#: rounded up; all orders 0.051 %, max 0.19 %), checked on a held-out set (seed 1: 0.081 % at the
#: top order, one drive 0.45 % at its lowest: studies/results/loop_model_calibration.md).
MODEL_U_PU = 0.0008


def fit_loop(points, setup: LoopSetup, plant, u_inductance):
    """The gain g (Identified) from the complex H_k of ``points`` [(order, H, u)], with a frame
    offset δ (order k turned by k·δ) fitted beside it; the delay held at the documented one;
    ``plant`` = the measured (R, L), L's u ``u_inductance`` propagated."""
    orders = np.array([order for order, _, _ in points], dtype=float)
    measured = np.array([h for _, h, _ in points])
    quantisation, u_quantisation = angle_quantisation(orders, setup.count_elec_rad)
    weights = np.hypot([u for _, _, u in points],
                       np.abs(measured) * np.hypot(MODEL_U_PU, u_quantisation))

    def predicted(x, plant_):
        return model_response(orders * setup.omega_e_rad_s, x[0], plant_, setup) \
            * quantisation * np.exp(1j * orders * x[1])

    def residual(x, plant_=plant):
        error = (predicted(x, plant_) - measured) / weights
        return np.concatenate([error.real, error.imag])

    start = _frame_start(predicted((1.0, 0.0), plant), measured, orders)
    bounds = ([0.05, -math.inf], [5.0, math.inf])
    fit = least_squares(residual, [1.0, start], bounds=bounds)
    chi2 = float(np.sum(fit.fun ** 2)) / max(2 * len(points) - 2, 1)
    cov = np.linalg.pinv(fit.jac.T @ fit.jac) * max(1.0, chi2)
    # the measured L's u: refit with L + u_L
    shifted = least_squares(lambda x: residual(x, (plant[0], plant[1] + u_inductance)),
                            fit.x, bounds=bounds).x
    u_gain = math.hypot(math.sqrt(cov[0, 0]), shifted[0] - fit.x[0])
    return Identified("current_loop_gain_pu", float(fit.x[0]), u_gain, "1",
                      _method(orders, setup, fit.x[1], chi2))


def _method(orders, setup: LoopSetup, frame_rad: float, chi2: float) -> str:
    listed = ", ".join(str(int(order)) for order in orders)
    return (f"the drive's loop test signal (0x200C/0x200D: A·sin(k·θe) on i_q*) at electrical "
            f"orders {listed}; i_q from ia_a, ib_a and the angle channel turned to the drive's "
            f"frame (where it holds its mean current); the documented design (PI Kp = g·ωc·L0, "
            f"Ki = g·ωc·R0, ωc = 2π·{setup.bandwidth_hz:g} Hz, run at {setup.pwm_hz:g} Hz, "
            f"delay {setup.delay_s * 1e6:.3g} µs held) on the measured R, L: the continuous "
            f"current's response to the PWM pulses; g and a frame offset δ = "
            f"{frame_rad * 1e3:.3g} mrad (elec.) fitted to the complex response by weighted "
            f"least squares (χ²/dof {chi2:.2g}); g = 1 is the documented loop")


def _frame_start(predicted, measured, orders) -> float:
    """δ to start from: the lowest order's phase against the documented loop's (g = 1), per
    order (its phase depends least on g)."""
    low = int(np.argmin(orders))
    return float(np.angle(measured[low] / predicted[low])) / orders[low]
