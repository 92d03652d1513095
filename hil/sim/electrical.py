"""The PMSM's electrical model and its exact solution between switching instants (compiled).

Each phase: L·di/dt + R·i = v_xn − e_x (star connection). With the rotor speed constant over a PWM
period, θe(τ) = θe0 + ωe·τ and every EMF harmonic is a sinusoid of time, so the current splits
exactly into i = X + i_e where i_e is the *forced response* to the EMF,

    i_e,x = −Σ_h  ψ_h·ω_m / |R + j·h·ωe·L| · sin(h·(θe − 2πx/3) + φ_h − ∠(R + j·h·ωe·L)),

and X obeys L·dX/dt + R·X = u with u piecewise constant (the inverter's leg voltages), so
X(τ) = X0·a + (u/R)·(1 − a), a = exp(−R·τ/L). No step grid, no truncation error: besides float64
rounding, the only approximation is the polynomial sin/cos/exp of small arguments (< 1e-13).
With an isolated neutral the zero-sequence (triplen) EMF drives no current and
u_x = v_xo − mean(v_o); when one phase is held at zero current
by its diodes (dead time) the other two carry ±i with u = (v_mo − v_no)/2 and EMF (e_m − e_n)/2,
whose forced response is (i_e,m − i_e,n)/2.
"""

from __future__ import annotations

import math

from numba import njit

from hil.sim.layout import P_HARM, P_L, P_N_HARM, P_NEUTRAL, P_POLE_PAIRS, P_PSI, P_R

SIN_120 = math.sqrt(3.0) / 2.0
#: LLVM fast-math flags for the hot loop: contraction to FMA and reassociation, but NaN and
#: infinity handling kept (the engine uses neither, and must not have them optimised away)
FAST_MATH = {"contract", "reassoc", "nsz", "arcp", "afn"}
MAX_HARMONICS = 5          # fundamental + up to 4 harmonics
BASIS_COLUMNS = 6


# Taylor coefficients, evaluated by Estrin's scheme (pairs, then powers of the argument): the
# same polynomials as Horner's rule to rounding, with a dependency chain of ~4 operations
# instead of 12 (the engine's loop is bound by such chains, not by arithmetic throughput)
_S = tuple((-1.0) ** k / math.factorial(2 * k + 1) for k in range(7))
_C = tuple((-1.0) ** k / math.factorial(2 * k) for k in range(7))
_E = tuple(1.0 / math.factorial(k) for k in range(13))


@njit(cache=True, error_model="numpy", fastmath=FAST_MATH)
def sincos_small(x):
    """(sin x, cos x); Taylor series to x^12 for |x| <= 0.5 (error < 1e-13), libm beyond."""
    if abs(x) > 0.5:
        return math.sin(x), math.cos(x)
    y = x * x
    y2 = y * y
    y4 = y2 * y2
    s = (_S[0] + _S[1] * y) + y2 * (_S[2] + _S[3] * y) + y4 * ((_S[4] + _S[5] * y) + y2 * _S[6])
    c = (_C[0] + _C[1] * y) + y2 * (_C[2] + _C[3] * y) + y4 * ((_C[4] + _C[5] * y) + y2 * _C[6])
    return x * s, c


@njit(cache=True, error_model="numpy", fastmath=FAST_MATH)
def exp_small(x):
    """exp(x); Taylor series to x^12 for |x| <= 0.5 (error < 1e-13 relative), libm beyond."""
    if abs(x) > 0.5:
        return math.exp(x)
    x2 = x * x
    x4 = x2 * x2
    x8 = x4 * x4
    low = (_E[0] + _E[1] * x) + x2 * (_E[2] + _E[3] * x) \
        + x4 * ((_E[4] + _E[5] * x) + x2 * (_E[6] + _E[7] * x))
    high = (_E[8] + _E[9] * x) + x2 * (_E[10] + _E[11] * x) + x4 * _E[12]
    return low + x8 * high


@njit(cache=True, error_model="numpy", fastmath=FAST_MATH)
def spread(order, s, c):
    """sin(α − order·x·2π/3) for phases x = a, b, c, from s = sin α and c = cos α."""
    shift = order % 3
    if shift == 0:
        return s, s, s
    lag = -0.5 * s - SIN_120 * c        # sin(α − 2π/3)
    lead = -0.5 * s + SIN_120 * c       # sin(α + 2π/3)
    if shift == 1:
        return s, lag, lead
    return s, lead, lag


@njit(cache=True, error_model="numpy", fastmath=False)
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


# columns of the per-period basis: forced-response gain (A) and the sin/cos of its angle at the
# period start; EMF amplitude per mechanical rad/s (V·s/rad) and the sin/cos of its angle
B_GAIN, B_FSIN, B_FCOS, B_EMF, B_ESIN, B_ECOS = 0, 1, 2, 3, 4, 5


@njit(cache=True, error_model="numpy", fastmath=FAST_MATH)
def impedance_angles(params, omega_m, orders, amplitudes, count, lag):
    """Per harmonic: forced-response gain (A) and sin/cos of the impedance angle ∠(R + j·h·ωe·L)
    into ``lag[k] = (gain, sin, cos)``; they change only with the speed."""
    resistance = params[P_R]
    inductance = params[P_L]
    omega_e = params[P_POLE_PAIRS] * omega_m
    isolated = params[P_NEUTRAL] == 0.0
    for k in range(count):
        if isolated and int(orders[k]) % 3 == 0:
            lag[k, 0] = 0.0                     # zero sequence: no current path
            continue
        reactance = orders[k] * omega_e * inductance
        magnitude = math.hypot(resistance, reactance)
        lag[k, 0] = -params[P_PSI] * amplitudes[k] * omega_m / magnitude
        lag[k, 1] = reactance / magnitude
        lag[k, 2] = resistance / magnitude


@njit(cache=True, error_model="numpy", fastmath=FAST_MATH)
def period_basis(params, theta_e0, orders, amplitudes, phases, count, lag, basis):
    """Per harmonic: EMF amplitude and forced-response gain with their angles at θe0."""
    for k in range(count):
        s = math.sin(orders[k] * theta_e0 + phases[k])
        c = math.cos(orders[k] * theta_e0 + phases[k])
        basis[k, B_EMF] = params[P_PSI] * amplitudes[k]
        basis[k, B_ESIN] = s
        basis[k, B_ECOS] = c
        basis[k, B_GAIN] = lag[k, 0]
        basis[k, B_FSIN] = s * lag[k, 2] - c * lag[k, 1]     # sin(angle − ∠Z)
        basis[k, B_FCOS] = c * lag[k, 2] + s * lag[k, 1]


@njit(cache=True, error_model="numpy", fastmath=FAST_MATH)
def _harmonic_terms(k, s_d, c_d, orders, basis):
    """Harmonic k's forced currents and EMF per speed (a, b, c), its angle advanced by the
    increment whose sin/cos are (s_d, c_d) since the period start."""
    order = int(orders[k])
    s = basis[k, B_ESIN] * c_d + basis[k, B_ECOS] * s_d
    c = basis[k, B_ECOS] * c_d - basis[k, B_ESIN] * s_d
    xa, xb, xc = spread(order, s, c)
    emf = basis[k, B_EMF]
    gain = basis[k, B_GAIN]
    if gain == 0.0:
        return 0.0, 0.0, 0.0, emf * xa, emf * xb, emf * xc
    s = basis[k, B_FSIN] * c_d + basis[k, B_FCOS] * s_d
    c = basis[k, B_FCOS] * c_d - basis[k, B_FSIN] * s_d
    fa, fb, fc = spread(order, s, c)
    return gain * fa, gain * fb, gain * fc, emf * xa, emf * xb, emf * xc


@njit(cache=True, error_model="numpy", fastmath=FAST_MATH, inline="always")
def _sum_harmonics(tau, omega_e, advance, given, orders, count, basis):
    """Σ over harmonics of ``_harmonic_terms``; each harmonic's angle increment since the period
    start is ``advance[k]`` if ``given``, else evaluated as orders[k]·ωe·τ. Inlined into its two
    callers, so ``given`` is a constant there (a runtime test per harmonic cost ~10 % of the
    loop)."""
    fa = fb = fc = ka = kb = kc = 0.0
    for k in range(count):
        if given:
            s_d = advance[k, 0]
            c_d = advance[k, 1]
        else:
            s_d, c_d = sincos_small(orders[k] * omega_e * tau)
        dfa, dfb, dfc, dka, dkb, dkc = _harmonic_terms(k, s_d, c_d, orders, basis)
        fa += dfa
        fb += dfb
        fc += dfc
        ka += dka
        kb += dkb
        kc += dkc
    return fa, fb, fc, ka, kb, kc


@njit(cache=True, error_model="numpy", fastmath=FAST_MATH)
def evaluate(tau, omega_e, orders, count, basis):
    """At τ into the period: forced currents i_e (A) and EMF per speed k_x (V·s/rad), a/b/c.

    e_x = ω_m·k_x; the electromagnetic torque is Σ k_x·i_x (= Σ e_x·i_x/ω_m, also at ω = 0).
    """
    return _sum_harmonics(tau, omega_e, basis, False, orders, count, basis)


@njit(cache=True, error_model="numpy", fastmath=FAST_MATH)
def evaluate_advanced(advance, count, orders, basis):
    """``evaluate`` where each harmonic's angle increment since the period start is given:
    ``advance[k] = (sin, cos)`` of orders[k]·ωe·τ (kept by rotation for equally spaced samples,
    see ``advance_by``)."""
    return _sum_harmonics(0.0, 0.0, advance, True, orders, count, basis)


@njit(cache=True, error_model="numpy", fastmath=FAST_MATH)
def advance_by(advance, step, count):
    """Rotate every harmonic's increment ``advance[k]`` by ``step[k]`` (both (sin, cos))."""
    for k in range(count):
        s = advance[k, 0] * step[k, 1] + advance[k, 1] * step[k, 0]
        c = advance[k, 1] * step[k, 1] - advance[k, 0] * step[k, 0]
        advance[k, 0] = s
        advance[k, 1] = c
