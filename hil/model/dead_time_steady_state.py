"""Periodic steady state of the average dead-time model with the current's own sign (clamping).

The paper's dead-time error (section III-D, eqs 32-37) is a leg voltage that depends on the
sign of that leg's current. ``hil.model.dead_time``'s harmonic series takes that sign from the
*ideal* sinusoidal currents, which makes the error a fixed six-step wave. In a drive the diodes
see the *actual* current: near each zero crossing the error ε = T_d·f_sw·V_dc flips as soon as the
current does, opposing it, so the current dwells at zero (zero-current clamping) until the loop
and the phase voltage have moved by about 2ε. The dwell is short where the phase voltage sweeps
fast (high speed, high current: large E and R·I) and long where it is small against ε (low speed,
low current) — there the six-step series underestimates the order-6k harmonics (the dwell adds
pulses at every zero crossing, rich in orders 12, 18, …).

This module solves the same average model (per-PWM-period leg error −ε·sign(i_x), isolated
neutral, R-L phases with sinusoidal EMF, eq 1) with the sign of the simulated current, in the
time domain, until the periodic steady state, with the current loop the bench file states
(``hil.current_loop``, no decoupling): the PI Kp = ω_c·L_s, Ki = ω_c·R on both axes, or
the complex-vector 2-DOF PI whose integrator is fed from the applied voltage; its stationary
output is applied ``delay_s`` after it was computed, at the angle it was computed for or, with
angle compensation, at the angle advanced by ω_e·``delay_s``. Forward Euler with a
step small enough that the sign's chatter at a clamp (2ε·dt/L_s) stays below 0.2 % of the current.
Returned: torque Σ e_x·i_x/ω_m per unit of the ideal (3/2)·E·I·cos φ/ω_m over one electrical
revolution, against the electrical angle.

PWM current ripple at the crossings (``dc_bus_v`` and ``pwm_frequency_hz`` given). Eqs 32-37 set
a leg's error by the current *during each dead interval*: the diodes hold a dead leg low for
i > 0 and high for i < 0, so a rising edge with i > 0 loses T_d·V_dc and a falling edge with
i < 0 gains it. In a centre-aligned period the ripple is odd about the centre: the current at the
leg's rising edge is i − a_x and at its falling edge i + a_x (i the period average), with

    a_x = V_dc/(2·L·f_pwm) · [d_x − (1/3)·Σ_y min(d_y, d_x) − d_x·(d_x − mean d)]

(duties d_y of the commanded voltages under SVPWM min-max; R and EMF changes within a period
neglected). Within |i| < |a_x| the two edges see opposite signs and their errors cancel. A dead
interval that starts near zero current moves it with the slope of the diode's state
((±V_dc-step phase voltage − average)/L); reaching zero with both states' slopes pointing back,
the current stays at zero for the rest of the interval and the leg floats where di/dt = 0
(``_low_time``; the simulated drive's current sits at zero at its ripple peaks for several
periods there). The per-period leg error is V_dc·f_pwm·(T_d − t_low,rise − t_low,fall), which is
−ε·sign(i) far from the crossing. Without the ripple the model read 30 % low at Table I
1000 rpm / 5 A, 2 µs (a_x ≈ 0.64 A of 5 A; the simulated drive's ripple there ±0.65-0.71 A).
"""

from __future__ import annotations

import functools
import math

import numpy as np
from numba import njit

from hil.current_loop import LoopGains, pi_gains

#: chatter of the explicit sign at a clamp, per unit of the current amplitude
CHATTER_PU = 0.002
#: at most this many steps per electrical revolution (bounds the run time at very low speed)
MAX_STEPS_PER_REV = 400_000


@njit(cache=True, fastmath=False)
def _low_time(i0, s_low, s_high, t_d):
    """Time (s) a dead leg spends at the low rail, counting a clamp at zero current as the
    fraction of the interval its floating voltage lies below the high rail, over a dead interval
    of ``t_d`` that starts with the phase current ``i0`` (A). While dead the diodes set the leg:
    low for i > 0, high for i < 0; the current then moves with that state's slope (``s_low``,
    ``s_high``, A/s; s_high − s_low = (2/3)·V_dc/L > 0). Reaching zero with both slopes pointing
    back at it, the current stays at zero and the leg floats at b = −s_low/(s_high − s_low) of the
    bus (the level where di/dt = 0)."""
    if i0 == 0.0:
        if s_low >= 0.0:
            return t_d
        if s_high <= 0.0:
            return 0.0
        return t_d * s_high / (s_high - s_low)
    if i0 > 0.0:
        if s_low >= 0.0 or i0 >= -s_low * t_d:
            return t_d                          # stays positive: low throughout
        t_zero = i0 / -s_low
        if s_high > 0.0:                        # clamped at zero for the rest
            return t_zero + (t_d - t_zero) * s_high / (s_high - s_low)
        return t_zero                           # goes on negative: high for the rest
    if s_high <= 0.0 or -i0 >= s_high * t_d:
        return 0.0                              # stays negative: high throughout
    t_zero = -i0 / s_high
    if s_low < 0.0:
        return (t_d - t_zero) * s_high / (s_high - s_low)
    return t_d - t_zero                         # goes on positive: low for the rest


@njit(cache=True, fastmath=False)
def _leg_errors(u, cur, v_dc, l, f_pwm, t_d, out):
    """Per-period average leg voltage error (V) of each leg with its dead times (module
    docstring): the commanded phase voltages ``u`` (V) under centre-aligned SVPWM (min-max zero
    sequence), the period-average phase currents ``cur`` (A)."""
    z = -0.5 * (max(u[0], max(u[1], u[2])) + min(u[0], min(u[1], u[2])))
    d = np.empty(3)
    for x in range(3):
        d[x] = min(1.0, max(0.0, 0.5 + (u[x] + z) / v_dc))
    mean = (d[0] + d[1] + d[2]) / 3.0
    for x in range(3):
        shared = 0.0
        others_high = 0
        for y in range(3):
            shared += min(d[y], d[x]) / 3.0
            if y != x and d[y] > d[x]:
                others_high += 1
        # the ripple's excursion from the period average at the leg's edges (a_x, signed)
        excursion = v_dc / (2.0 * l * f_pwm) * (d[x] - shared - d[x] * (d[x] - mean))
        average_v = v_dc * (d[x] - mean)
        s_high = (v_dc * (2.0 - others_high) / 3.0 - average_v) / l
        s_low = (-v_dc * others_high / 3.0 - average_v) / l
        low_rise = _low_time(cur[x] - excursion, s_low, s_high, t_d)
        low_fall = _low_time(cur[x] + excursion, s_low, s_high, t_d)
        # rising edge: the leg should be high (deficit low_rise); falling: low (excess t_d − low)
        out[x] = v_dc * f_pwm * (t_d - low_rise - low_fall)


@njit(cache=True, fastmath=False)
def _run(r, l, emf, w_e, amp, phi, eps, kp, ki_re, ki_im, kr_re, kr_im, advance_rad, dt,
         delay_steps, settle_steps, rev_steps, v_dc, f_pwm, t_d):
    offsets = (0.0, 2.0 * math.pi / 3.0, -2.0 * math.pi / 3.0)
    cur = np.empty(3)
    for x in range(3):
        cur[x] = amp * math.sin(-phi - offsets[x])
    # integrators start at the voltage the ideal currents need (the loop then settles the rest)
    z1 = r * amp + emf * math.cos(phi)
    z2 = w_e * l * amp + emf * math.sin(phi)
    size = delay_steps + 1
    pending = np.zeros((size, 3))
    for k in range(size):
        psi0 = w_e * (k - delay_steps) * dt - phi + advance_rad
        for x in range(3):
            pending[k, x] = z1 * math.sin(psi0 - offsets[x]) + z2 * math.cos(psi0 - offsets[x])
    head = 0
    theta_out = np.empty(rev_steps)
    torque_out = np.empty(rev_steps)
    total = settle_steps + rev_steps
    v = np.empty(3)
    e = np.empty(3)
    errors = np.zeros(3)
    for n in range(total):
        theta = w_e * n * dt
        psi = theta - phi
        err1 = amp
        err2 = 0.0
        for x in range(3):
            err1 -= 2.0 / 3.0 * cur[x] * math.sin(psi - offsets[x])
            err2 -= 2.0 / 3.0 * cur[x] * math.cos(psi - offsets[x])
        z1 += (ki_re * err1 - ki_im * err2) * dt
        z2 += (ki_re * err2 + ki_im * err1) * dt
        u1 = kp * err1 + z1
        u2 = kp * err2 + z2
        # ring buffer: write the new command (at the advanced angle), read the one computed
        # delay_steps ago
        slot = (head + delay_steps) % size
        for x in range(3):
            pending[slot, x] = (u1 * math.sin(psi + advance_rad - offsets[x])
                                + u2 * math.cos(psi + advance_rad - offsets[x]))
        if kr_re != 0.0 or kr_im != 0.0:
            # the integrator also sees the applied minus the computed voltage (rotor frame)
            a1 = -u1
            a2 = -u2
            for x in range(3):
                a1 += 2.0 / 3.0 * pending[head, x] * math.sin(psi - offsets[x])
                a2 += 2.0 / 3.0 * pending[head, x] * math.cos(psi - offsets[x])
            z1 += (kr_re * a1 - kr_im * a2) * dt
            z2 += (kr_re * a2 + kr_im * a1) * dt
        if t_d > 0.0:
            _leg_errors(pending[head], cur, v_dc, l, f_pwm, t_d, errors)
        for x in range(3):
            e[x] = emf * math.sin(theta - offsets[x])
            if t_d > 0.0:
                v[x] = pending[head, x] + errors[x]
            else:
                sign = 1.0 if cur[x] > 0.0 else (-1.0 if cur[x] < 0.0 else 0.0)
                v[x] = pending[head, x] - eps * sign
        head = (head + 1) % size
        neutral = (v[0] + v[1] + v[2] - e[0] - e[1] - e[2]) / 3.0
        if n >= settle_steps:
            m = n - settle_steps
            theta_out[m] = theta
            torque_out[m] = (math.sin(theta) * cur[0] + math.sin(theta - offsets[1]) * cur[1]
                             + math.sin(theta - offsets[2]) * cur[2])
        for x in range(3):
            cur[x] += dt * (v[x] - neutral - r * cur[x] - e[x]) / l
    return theta_out, torque_out


def steady_state_torque_orders(**inputs) -> np.ndarray:
    """:func:`torque_orders` (its arguments, by keyword); a run's pre-flight and its measurement
    ask for the same point's prediction, so the last results are kept (a copy is returned)."""
    return _kept_torque_orders(**inputs).copy()


@functools.lru_cache(maxsize=64)
def _kept_torque_orders(**inputs) -> np.ndarray:
    coefficients = torque_orders(**inputs)
    coefficients.flags.writeable = False
    return coefficients


def torque_orders(*, resistance_ohm: float, inductance_h: float, emf_peak_v: float,
                  elec_speed_rad_s: float, current_a: float, current_angle_rad: float,
                  leg_error_v: float, loop_bandwidth_rad_s: float, delay_s: float,
                  max_order: int, dc_bus_v: float = 0.0,
                  pwm_frequency_hz: float = 0.0,
                  loop_resistance_ohm: float | None = None,
                  loop_inductance_h: float | None = None,
                  loop_gains: LoopGains | None = None,
                  angle_compensation: bool = False) -> np.ndarray:
    """Complex order coefficients c_k (k = 0..max_order) of the torque per unit of the ideal,
    torque(θ) = Re Σ c_k·e^{jkθ} (c_0 real: the mean per unit), θ the electrical angle.

    ``emf_peak_v`` is signed with the speed (e_a = emf_peak_v·sin θ, θ = ω_e·t); ``leg_error_v``
    is ε = T_d·f_sw·V_dc (V). A loop bandwidth of 0 runs voltage-fed (no loop). With
    ``dc_bus_v`` (V) and ``pwm_frequency_hz`` (Hz) both > 0 the leg error comes from the current at
    the leg's edges with the PWM ripple and the clamping in the dead intervals (module
    docstring); with either 0 it is the plain −ε·sign(i). The loop: ``loop_gains``
    (``hil.current_loop``: u = K_p·e + z, dz/dt = K_i·e + K_r·(u_applied − u); the design's
    bandwidth ``loop_bandwidth_rad_s`` sets the step and the settling), or None: the PI
    Kp = L·ωc, Ki = R·ωc at ωc = ``loop_bandwidth_rad_s`` with ``loop_resistance_ohm`` and
    ``loop_inductance_h``, the R and L it was designed with (None: the motor's).
    ``angle_compensation``: the voltage applied at the angle advanced by ω_e·``delay_s``.
    """
    w = elec_speed_rad_s
    period = 2.0 * math.pi / abs(w)
    amp = current_a
    dt_max = CHATTER_PU * amp * inductance_h / max(2.0 * leg_error_v, 1e-12)
    if loop_bandwidth_rad_s > 0.0:
        dt_max = min(dt_max, 0.05 / loop_bandwidth_rad_s)
    if delay_s > 0.0:
        dt_max = min(dt_max, delay_s / 8.0)
    dt_max = min(dt_max, 0.05 * inductance_h / resistance_ohm)
    rev_steps = int(min(MAX_STEPS_PER_REV, max(2000, math.ceil(period / dt_max))))
    dt = period / rev_steps
    # settle: one revolution and 20 time constants of the slowest mode (L/R, the loop)
    slow = inductance_h / resistance_ohm + (1.0 / loop_bandwidth_rad_s if loop_bandwidth_rad_s
                                            else 0.0)
    settle_steps = int(math.ceil(max(period, 20.0 * slow) / dt))
    gains = loop_gains or pi_gains(
        loop_bandwidth_rad_s,
        resistance_ohm=resistance_ohm if loop_resistance_ohm is None else loop_resistance_ohm,
        inductance_h=inductance_h if loop_inductance_h is None else loop_inductance_h)
    ki, kr = gains.integral_v_per_a_s, gains.realised_feedback_per_s
    theta, torque = _run(resistance_ohm, inductance_h, emf_peak_v, w, amp, current_angle_rad,
                         leg_error_v, gains.proportional_v_per_a, ki.real, ki.imag, kr.real,
                         kr.imag, w * delay_s if angle_compensation else 0.0, dt,
                         int(round(delay_s / dt)), settle_steps, rev_steps, float(dc_bus_v), float(pwm_frequency_hz),
                         leg_error_v / (dc_bus_v * pwm_frequency_hz)
                         if dc_bus_v > 0.0 and pwm_frequency_hz > 0.0 else 0.0)
    per_unit = torque / (1.5 * amp * math.cos(current_angle_rad))
    # uniform in time over one revolution = uniform in θ (decreasing when w < 0)
    spectrum = np.fft.fft(per_unit) / rev_steps if w > 0 else np.fft.ifft(per_unit)
    orders = np.arange(max_order + 1)
    coefficients = spectrum[:max_order + 1] * np.exp(-1j * orders * theta[0])
    coefficients[1:] *= 2.0
    return coefficients
