"""The PMSM's electrical model and its exact solution between switching instants (compiled).

Each phase: L·di/dt + R·i = v_xn − e_x (star connection). With the rotor speed constant over a PWM
period, θe(τ) = θe0 + ωe·τ and every EMF harmonic is a sinusoid of time, so the current splits
exactly into i = X + i_e where i_e is the *forced response* to the EMF,

    i_e,x = −Σ_h  ψ_h·ω_m / |R + j·h·ωe·L| · sin(h·(θe − 2πx/3) + φ_h − ∠(R + j·h·ωe·L)),

and X obeys L·dX/dt + R·X = u with u piecewise constant (the inverter's leg voltages), so
X(τ) = X0·a + (u/R)·(1 − a), a = exp(−R·τ/L). No step grid, no truncation error: the only
approximation in this module is float64 rounding. With an isolated neutral the zero-sequence
(triplen) EMF drives no current and u_x = v_xo − mean(v_o); when one phase is held at zero current
by its diodes (dead time) the other two carry ±i with u = (v_mo − v_no)/2 and EMF (e_m − e_n)/2,
whose forced response is (i_e,m − i_e,n)/2.
"""

from __future__ import annotations

import math

from numba import njit

from hil.sim.layout import P_HARM, P_L, P_N_HARM, P_NEUTRAL, P_POLE_PAIRS, P_PSI, P_R

SIN_120 = math.sqrt(3.0) / 2.0
MAX_HARMONICS = 5          # fundamental + up to 4 harmonics


@njit(cache=True)
def three_phase(order, argument):
    """sin(argument − order·x·2π/3) for phases x = a, b, c (balanced set of harmonic ``order``)."""
    s = math.sin(argument)
    c = math.cos(argument)
    shift = order % 3
    if shift == 0:
        return s, s, s
    lag = -0.5 * s - SIN_120 * c        # sin(argument − 2π/3)
    lead = -0.5 * s + SIN_120 * c       # sin(argument + 2π/3)
    if shift == 1:
        return s, lag, lead
    return s, lead, lag


@njit(cache=True)
def harmonic_table(params, orders, amplitudes, phases):
    """Fill the EMF harmonic set (fundamental first); returns how many entries are used."""
    orders[0] = 1.0
    amplitudes[0] = 1.0
    phases[0] = 0.0
    count = 1
    for k in range(int(params[P_N_HARM])):
        orders[count] = params[P_HARM + 3 * k]
        amplitudes[count] = params[P_HARM + 3 * k + 1]
        phases[count] = params[P_HARM + 3 * k + 2]
        count += 1
    return count


@njit(cache=True)
def forced_coefficients(params, omega_m, orders, amplitudes, phases, count, gains, shifts):
    """Per-harmonic amplitude (A) and phase shift of the forced response i_e at speed ω_m."""
    resistance = params[P_R]
    inductance = params[P_L]
    omega_e = params[P_POLE_PAIRS] * omega_m
    isolated = params[P_NEUTRAL] == 0.0
    for k in range(count):
        order = orders[k]
        if isolated and int(order) % 3 == 0:
            gains[k] = 0.0                      # zero sequence: no current path
            shifts[k] = 0.0
            continue
        reactance = order * omega_e * inductance
        gains[k] = -params[P_PSI] * amplitudes[k] * omega_m / math.hypot(resistance, reactance)
        shifts[k] = phases[k] - math.atan2(reactance, resistance)


@njit(cache=True)
def forced_response(theta_e, orders, gains, shifts, count):
    """The EMF-driven currents i_e (A) of phases a, b, c at electrical angle θe."""
    ra = 0.0
    rb = 0.0
    rc = 0.0
    for k in range(count):
        if gains[k] == 0.0:
            continue
        sa, sb, sc = three_phase(int(orders[k]), orders[k] * theta_e + shifts[k])
        ra += gains[k] * sa
        rb += gains[k] * sb
        rc += gains[k] * sc
    return ra, rb, rc


@njit(cache=True)
def emf_per_speed(theta_e, params, orders, amplitudes, phases, count):
    """Back EMF per mechanical rad/s of phases a, b, c (V·s/rad): e_x = ω_m·k_x(θe)."""
    ka = 0.0
    kb = 0.0
    kc = 0.0
    psi = params[P_PSI]
    for k in range(count):
        sa, sb, sc = three_phase(int(orders[k]), orders[k] * theta_e + phases[k])
        ka += psi * amplitudes[k] * sa
        kb += psi * amplitudes[k] * sb
        kc += psi * amplitudes[k] * sc
    return ka, kb, kc
