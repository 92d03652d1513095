"""The engine: one compiled loop over PWM periods, exact between switching instants.

Per period: the dyno sets the speed; the firmware runs at the counter valley and latches compare
values for the *next* period (``FirmwareModel.delay_periods`` = 1; with 0 they apply in the same
period; with 0.5 or 1.5 the firmware samples at the counter peak, on the exact current there, and
its values apply from the next valley or the one after); the three legs' gate states
(centre-aligned, edges exactly where the up/down counter meets the compare value, dead time after
every edge) cut the period into at most 13 segments of constant gate state; in each the currents follow the exact solution of
``hil.sim.electrical``. During a dead interval a leg's voltage is set by its current's sign (diode
conduction); a zero crossing there is an event (located by bisection on the exact solution to
~1e-14 s) after which the phase is held at zero while the floating terminal voltage stays between
the rails. Where a dead leg's current provably keeps its sign (|i| above a bound on its change),
the dead interval merely extends the neighbouring gate state and its boundary is skipped (same
solution, fewer steps). Outputs are the exact solution evaluated at the sample instants (the
first sample of a sub-segment directly, the next equally spaced ones by recurrence: decays
multiplied, harmonic angles rotated by a per-sample step; within ~1e-12 of the peak of direct
evaluation). State lives in a flat array so a later call continues where this one stopped.

Approximations (stated): the speed is constant within a PWM period (the dyno's profile is
piecewise linear in angle at period resolution); the transducer's first-order filter is driven by
the shaft torque interpolated linearly within each segment (at most half a PWM period: 25 µs at
20 kHz against its 159 µs time constant at 1 kHz; coarser at the lowest PWM frequencies); gates
off means zero current (valid while the line-to-line EMF peak is below V_dc, i.e. below
~2000 rpm for Table I, else the diodes would rectify).

Floating-point flags: only the electrical solution (``hil.sim.electrical``'s per-period basis,
sin/cos/exp series and forced response, the current, torque and filter updates here and the
loop itself) runs under LLVM fast-math (``FAST_MATH``). Every other compiled function states
``fastmath=False``: numba gives a function that states nothing the flags of the function it is
first compiled inside, so the firmware's truncation decisions (``hil.sim.firmware``) and the
dyno profile would otherwise depend on compile order. Instructions keep their own flags when
inlined, so the firmware stays exact inside the fast-math loop.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from hil.sim import compiled_cache  # noqa: F401  (before any compiled code runs)
from hil.sim.electrical import (B_ECOS, B_ESIN, B_GAIN, BASIS_COLUMNS, FAST_MATH, MAX_HARMONICS,
                                advance_by, evaluate, evaluate_advanced, exp_small,
                                harmonic_table, impedance_angles, period_basis, sincos_small,
                                spread)
from hil.sim.firmware import (ANGLE_CACHE_ROWS, A_INDEX, adc_read, encoder_count,
                              K_ADC_HALF, firmware_constants, firmware_step)
from hil.sim.layout import (C_COUNTS, C_IA, C_IA_SENSED, C_IB, C_IB_SENSED, C_IC, C_ID, C_IQ,
                            C_SPEED_RPM, C_THETA_M, C_TIME, C_TORQUE_EM, C_TORQUE_SHAFT,
                            C_TORQUE_SHAFT_FILTERED, C_VA, C_VB, C_VC, P_ADC_FS,
                            P_COG, P_DEAD_TIME, P_DWELL, P_DYNO_MODE, P_ENABLED, P_ENC_CPR,
                            P_IA_GAIN, P_IA_OFFSET, P_IB_GAIN, P_IB_OFFSET, P_L, P_L_SAT,
                            P_LOOP_DELAY, P_WARM_RISE, P_WARM_TAU,
                            P_MERGE_SEGMENTS, P_N_COG, P_NEUTRAL, P_POLE_PAIRS, P_PWM_COUNTS,
                            P_PWM_FREQ, P_R, P_RAMP, P_SPEED_CMD, P_STEP_ANGLE, P_TR_TAU, P_VDC,
                            S_CMP_A, S_CMP_B, S_CMP_C, S_CMP_PENDING, S_HIGH_END, S_IA, S_IB,
                            S_IC, S_INITIALISED, S_INT_D, S_INT_Q, S_ISENSE_A, S_ISENSE_B,
                            S_OMEGA_M, S_THETA_M, S_TIME, S_TR_Y, S_WARM)

TWO_PI = 2.0 * math.pi
RPM = TWO_PI / 60.0
LOW, HIGH, DEAD = 0, 1, 2
MODE_FREE, MODE_ONE_CLAMPED, MODE_ZERO = 0, 1, 2
BISECTIONS = 36


@njit(cache=True, error_model="numpy", fastmath=False)
def dyno_speed(params, state, time_s, period_s):
    """Mechanical speed (rad/s) the dyno imposes over the period starting at ``time_s``."""
    command = params[P_SPEED_CMD] * RPM
    mode = params[P_DYNO_MODE]
    if mode == 1.0:                                   # slew-rate limited ramp
        step = params[P_RAMP] * RPM * period_s
        previous = state[S_OMEGA_M]
        omega = min(max(command, previous - step), previous + step)
    elif mode == 2.0:                                 # dwell / move / dwell ... (position profile)
        if command == 0.0:
            omega = 0.0
        else:
            angle0 = _stepping_angle(time_s, params, abs(command))
            angle1 = _stepping_angle(time_s + period_s, params, abs(command))
            omega = math.copysign(1.0, command) * (angle1 - angle0) / period_s
    else:
        omega = command
    state[S_OMEGA_M] = omega
    return omega


@njit(cache=True, error_model="numpy", fastmath=False)
def _stepping_angle(time_s, params, speed):
    step = params[P_STEP_ANGLE]
    dwell = params[P_DWELL]
    cycle = dwell + step / speed
    cycles = np.floor(time_s / cycle)
    within = time_s - cycles * cycle
    moving = min(max((within - dwell) * speed, 0.0), step)
    return cycles * step + moving


@njit(cache=True, error_model="numpy", fastmath=FAST_MATH)
def _sort(values, tags, count):
    """In-place insertion sort of values[:count] (a handful of switching instants), carrying
    ``tags`` (the leg each instant belongs to) along."""
    for i in range(1, count):
        v = values[i]
        t = tags[i]
        j = i - 1
        while j >= 0 and values[j] > v:
            values[j + 1] = values[j]
            tags[j + 1] = tags[j]
            j -= 1
        values[j + 1] = v
        tags[j + 1] = t


@njit(cache=True, error_model="numpy", fastmath=FAST_MATH)
def _leg_state(tau, t_on, t_off, dead, compare, counts_top, high_before):
    """Gate state of a leg at τ within the period (centre-aligned, dead time after each edge).

    ``high_before``: the leg ended the previous period high (compare = counter top, no edge).
    """
    if high_before:
        if compare >= counts_top:
            return HIGH
        if tau < dead:
            return DEAD                               # high -> low at the period start
    if compare <= 0.0 or tau < t_on:
        return LOW
    if t_off - t_on > dead:
        if tau < t_on + dead:
            return DEAD
        if tau < t_off:
            return HIGH
        if tau < t_off + dead:
            return DEAD
        return LOW
    if tau < t_off + dead:
        return DEAD                                   # pulse shorter than the dead time
    return LOW


@njit(cache=True, error_model="numpy", fastmath=FAST_MATH)
def _currents(mode, clamped, k, x0, u, fa, fb, fc, decay, resistance):
    """Exact phase currents of a sub-segment, given the forced response i_e at that instant and
    decay = exp(−R·(τ − τa)/L) since the sub-segment start τa (see module electrical)."""
    if mode == MODE_ZERO:
        return 0.0, 0.0, 0.0
    if mode == MODE_FREE:
        ia = fa + x0[0] * decay + u[0] / resistance * (1.0 - decay)
        ib = fb + x0[1] * decay + u[1] / resistance * (1.0 - decay)
        ic = fc + x0[2] * decay + u[2] / resistance * (1.0 - decay)
        if clamped & 1:
            ia = 0.0
        if clamped & 2:
            ib = 0.0
        if clamped & 4:
            ic = 0.0
        return ia, ib, ic
    # one phase (k) held at zero: the other two carry ±i (see module electrical)
    drift = x0[0] * decay + u[0] / resistance * (1.0 - decay)
    if k == 0:
        ib = 0.5 * (fb - fc) + drift
        return 0.0, ib, -ib
    if k == 1:
        ic = 0.5 * (fc - fa) + drift
        return -ic, 0.0, ic
    ia = 0.5 * (fa - fb) + drift
    return ia, -ia, 0.0


@njit(cache=True, error_model="numpy", fastmath=FAST_MATH)
def _currents_at(tau, tau_a, mode, clamped, k, x0, u, omega_e, orders, count, basis,
                 resistance, inductance):
    """``_currents`` at an arbitrary τ of the sub-segment (evaluates the forced response)."""
    fa, fb, fc, _, _, _ = evaluate(tau, omega_e, orders, count, basis)
    decay = exp_small(-resistance * (tau - tau_a) / inductance)
    return _currents(mode, clamped, k, x0, u, fa, fb, fc, decay, resistance)


@njit(cache=True, error_model="numpy", fastmath=FAST_MATH)
def _cogging_basis(params, theta_m0, cogging):
    """Rows (mechanical order, amplitude N·m, sin, cos of the cogging angle at θm0)."""
    for c in range(int(params[P_N_COG])):
        order = params[P_COG + 3 * c]
        angle = order * theta_m0 + params[P_COG + 3 * c + 2]
        cogging[c, 0] = order
        cogging[c, 1] = params[P_COG + 3 * c + 1]
        cogging[c, 2] = math.sin(angle)
        cogging[c, 3] = math.cos(angle)


@njit(cache=True, error_model="numpy", fastmath=FAST_MATH)
def _shaft_torque(tau, omega_m, k_a, k_b, k_c, ia, ib, ic, n_cogging, cogging):
    """(electromagnetic Σ e_x·i_x/ω_m, shaft = electromagnetic + cogging) in N·m at τ."""
    electromagnetic = k_a * ia + k_b * ib + k_c * ic
    total = electromagnetic
    for c in range(n_cogging):
        s_d, c_d = sincos_small(cogging[c, 0] * omega_m * tau)
        total += cogging[c, 1] * (cogging[c, 2] * c_d + cogging[c, 3] * s_d)
    return electromagnetic, total


@njit(cache=True, error_model="numpy", fastmath=FAST_MATH)
def _filter(y0, x0, slope, h, tau_f):
    """First-order low-pass output after h seconds of the input x0 + slope·t (exact)."""
    return _filter_decayed(y0, x0, slope, h, tau_f, exp_small(-h / tau_f))


@njit(cache=True, error_model="numpy", fastmath=FAST_MATH)
def _filter_decayed(y0, x0, slope, h, tau_f, decay):
    """``_filter`` given decay = exp(−h/τf)."""
    return x0 + slope * h - slope * tau_f + (y0 - x0 + slope * tau_f) * decay


@njit(cache=True, error_model="numpy", fastmath=FAST_MATH)
def plant_rl(params, state, ia, ib, ic, period):
    """(R, L) of the winding over the coming PWM period, quasi-static (constant within it).

    Saturation: L(|i|) = L/(1 + (|i|/i_sat)²), the inductance the voltage equation
    L·di/dt + R·i = v − e uses at the current vector's magnitude |i| = √(2/3·Σ i_x²) (the peak
    phase current of a balanced set) at the period start; isotropic (the same L on d and q).
    Warming: the resistance rise w (per unit of the cold R, ``state[S_WARM]``) is a first-order
    thermal state driven by the copper loss, τ·dw/dt = k·|i|² − w (k = ``P_WARM_RISE`` per A²,
    τ = ``P_WARM_TAU``), stepped exactly over the period for the period-start current; R = R·(1 + w).
    """
    magnitude2 = 2.0 / 3.0 * (ia * ia + ib * ib + ic * ic)
    resistance = params[P_R]
    inductance = params[P_L]
    if params[P_WARM_TAU] > 0.0:
        target = params[P_WARM_RISE] * magnitude2
        state[S_WARM] += (target - state[S_WARM]) * -math.expm1(-period / params[P_WARM_TAU])
        resistance *= 1.0 + state[S_WARM]
    if params[P_L_SAT] > 0.0:
        inductance /= 1.0 + magnitude2 / (params[P_L_SAT] * params[P_L_SAT])
    return resistance, inductance


@njit(cache=True, error_model="numpy", fastmath=FAST_MATH, nogil=True)
def run_drive(params, state, record_start_s, sample_dt_s, out, rows, latest, end_s):
    """Advance ``state`` over whole PWM periods until ``end_s``; record samples into ``out``.

    Sample j is taken at record_start_s + j·sample_dt_s (only those >= the state's time).
    ``rows[c]``: the row of ``out`` receiving engine channel c (``layout.C_*``), −1 = not wanted:
    only wanted channels are computed per sample (the state evolves identically either way).
    Encoder counts are written as int64 into their row's memory (``out[r].view(np.int64)``).
    ``latest`` (``N_CHANNELS``): every channel at the last sample (j = ``out.shape[1]`` − 1),
    whether wanted or not; channels not wanted per sample are evaluated directly there.
    Returns the state at the start of the last period run (the one containing ``end_s``): the
    caller keeps it and re-runs that period next time, so consecutive calls are continuous.
    Releases the GIL, so the simulated instruments' other threads (heartbeats) keep running.
    """
    n_samples = out.shape[1]
    last_j = n_samples - 1
    t_last = record_start_s + last_j * sample_dt_s
    need_cur = False                                  # per-sample currents (and what uses them)
    for c in (C_IA, C_IB, C_IC, C_TORQUE_EM, C_TORQUE_SHAFT, C_ID, C_IQ):
        if rows[c] >= 0:
            need_cur = True
    need_torque = rows[C_TORQUE_EM] >= 0 or rows[C_TORQUE_SHAFT] >= 0
    need_dq = rows[C_ID] >= 0 or rows[C_IQ] >= 0
    need_filter = rows[C_TORQUE_SHAFT_FILTERED] >= 0
    need_v = rows[C_VA] >= 0 or rows[C_VB] >= 0 or rows[C_VC] >= 0
    r_time, r_theta, r_counts, r_speed = rows[C_TIME], rows[C_THETA_M], rows[C_COUNTS], \
        rows[C_SPEED_RPM]
    r_isa, r_isb, r_filtered = rows[C_IA_SENSED], rows[C_IB_SENSED], \
        rows[C_TORQUE_SHAFT_FILTERED]
    r_ia, r_ib, r_ic, r_em, r_shaft = rows[C_IA], rows[C_IB], rows[C_IC], rows[C_TORQUE_EM], \
        rows[C_TORQUE_SHAFT]
    r_iq, r_id = rows[C_IQ], rows[C_ID]
    if r_counts >= 0:
        counts_out = out[r_counts].view(np.int64)
    else:
        counts_out = np.zeros(0, np.int64)
    t_filtered = sa = sb = sc = t_em = t_shaft = i_q = i_d = 0.0
    resistance = params[P_R]
    inductance = params[P_L]
    # the plant's R and L change from period to period (saturation, warming): a private copy
    # of the parameters carries them to the forced response (``impedance_angles``)
    varying = params[P_L_SAT] > 0.0 or params[P_WARM_TAU] > 0.0
    plant = params.copy()
    vdc = params[P_VDC]
    pole_pairs = params[P_POLE_PAIRS]
    isolated = params[P_NEUTRAL] == 0.0
    period = 1.0 / params[P_PWM_FREQ]
    counts_top = params[P_PWM_COUNTS]
    dead = params[P_DEAD_TIME]
    # a pulse must end a dead time before the period does; wider ones become full-on (no edge)
    constants = firmware_constants(params)
    adc_half = constants[K_ADC_HALF]
    enabled = params[P_ENABLED] != 0.0
    tau_f = params[P_TR_TAU]
    cpr = params[P_ENC_CPR]
    merge = params[P_MERGE_SEGMENTS] != 0.0
    immediate = params[P_LOOP_DELAY] == 0.0          # compare values apply in the same period
    mid_sampling = params[P_LOOP_DELAY] == 0.5 or params[P_LOOP_DELAY] == 1.5
    half_period = 0.5 * period
    peak_a = 0.0
    peak_b = 0.0

    orders = np.zeros(MAX_HARMONICS)
    amplitudes = np.zeros(MAX_HARMONICS)
    phases = np.zeros(MAX_HARMONICS)
    basis = np.zeros((MAX_HARMONICS, BASIS_COLUMNS))
    lag = np.zeros((MAX_HARMONICS, 3))
    n_cogging = int(params[P_N_COG])
    cogging = np.zeros((2, 4))
    lag_speed = math.nan
    count = harmonic_table(params, orders, amplitudes, phases)

    if state[S_INITIALISED] == 0.0:
        state[S_OMEGA_M] = params[P_SPEED_CMD] * RPM
        for x in range(3):
            state[S_CMP_A + x] = -1.0
            state[S_CMP_PENDING + x] = -1.0
        state[S_INITIALISED] = 1.0

    committed = state.copy()
    j = 0
    if state[S_TIME] > record_start_s:
        j = int(math.ceil((state[S_TIME] - record_start_s) / sample_dt_s - 1e-9))

    compare = np.zeros(3)
    t_on = np.zeros(3)
    t_off = np.zeros(3)
    gate = np.zeros(3, np.int64)
    volts = np.zeros(3)
    cur = np.zeros(3)
    x0 = np.zeros(3)
    u = np.zeros(3)
    v_integral = np.zeros(3)
    edges = np.zeros(20)
    edge_leg = np.zeros(20, np.int64)
    seg_gate = np.zeros((20, 3), np.int64)
    angle_cache = np.empty((ANGLE_CACHE_ROWS, 7))
    angle_cache[:, A_INDEX] = -1.0
    tiny = 1e-12 * period
    # equally spaced samples: per-sample decay factors and harmonic rotations (see below)
    advance = np.zeros((MAX_HARMONICS, 2))
    step = np.zeros((MAX_HARMONICS, 2))
    step_omega = math.nan
    decay_step = exp_small(-resistance * sample_dt_s / inductance)
    filter_step = exp_small(-sample_dt_s / tau_f)
    decay_s = 1.0
    filter_s = 1.0

    while state[S_TIME] < end_s:
        committed[:] = state
        t_period = state[S_TIME]
        omega = dyno_speed(params, state, t_period, period)
        omega_e = pole_pairs * omega
        speed_rpm = omega / RPM
        theta_m0 = state[S_THETA_M]
        theta_e0 = pole_pairs * theta_m0
        for x in range(3):
            compare[x] = state[S_CMP_A + x]
            cur[x] = state[S_IA + x]
        if varying:
            resistance, inductance = plant_rl(params, state, cur[0], cur[1], cur[2], period)
            plant[P_R] = resistance
            plant[P_L] = inductance
            decay_step = exp_small(-resistance * sample_dt_s / inductance)
            lag_speed = math.nan                      # the forced response changes with R, L

        # firmware at the valley: its compare values apply from the next period on (delay 1)
        # or from this one (delay 0); with delay 0.5 / 1.5 it runs at the peak instead (below)
        if enabled:
            if not mid_sampling:
                ca, cb, cc = firmware_step(cur[0], cur[1], theta_m0, omega, params, state,
                                           counts_top, constants, angle_cache)
                state[S_CMP_A] = ca
                state[S_CMP_B] = cb
                state[S_CMP_C] = cc
                if immediate:
                    compare[0] = ca
                    compare[1] = cb
                    compare[2] = cc
        else:
            for x in range(3):
                state[S_CMP_A + x] = -1.0
                state[S_CMP_PENDING + x] = -1.0
            state[S_INT_D] = 0.0
            state[S_INT_Q] = 0.0
            fs = params[P_ADC_FS]
            state[S_ISENSE_A] = fs * adc_read(cur[0], params[P_IA_OFFSET], params[P_IA_GAIN],
                                              fs, adc_half)
            state[S_ISENSE_B] = fs * adc_read(cur[1], params[P_IB_OFFSET], params[P_IB_GAIN],
                                              fs, adc_half)
            if immediate:
                compare[:] = -1.0
        peak_pending = enabled and mid_sampling

        gates_off = compare[0] < 0.0
        if gates_off:
            cur[:] = 0.0
        if omega != lag_speed:
            impedance_angles(plant, omega, orders, amplitudes, count, lag)
            lag_speed = omega
        period_basis(params, theta_e0, orders, amplitudes, phases, count, lag, basis)
        sin_e0 = basis[0, B_ESIN]                     # fundamental EMF angle is θe itself
        cos_e0 = basis[0, B_ECOS]

        n_edges = 0
        edges[n_edges] = 0.0
        edge_leg[n_edges] = -1
        n_edges += 1
        for x in range(3):
            t_on[x] = (counts_top - compare[x]) / counts_top * 0.5 * period
            t_off[x] = period - t_on[x]
            if state[S_HIGH_END + x] != 0.0 and compare[x] < counts_top:
                edges[n_edges] = dead
                edge_leg[n_edges] = x
                n_edges += 1
            if compare[x] > 0.0:
                for edge in (t_on[x], t_on[x] + dead, t_off[x], t_off[x] + dead):
                    edges[n_edges] = min(edge, period)
                    edge_leg[n_edges] = x
                    n_edges += 1
        edges[n_edges] = period
        edge_leg[n_edges] = -1
        n_edges += 1
        _sort(edges, edge_leg, n_edges)
        # gate states of every segment, at its middle. A leg's state changes only at its own
        # edges (``_leg_state``'s breakpoints are among them), so after the first segment only
        # the leg whose edge opens the segment is re-evaluated; all three where the segment is
        # (near) empty, since its middle may then round onto a tied edge of another leg
        for e in range(n_edges - 1):
            middle = 0.5 * (edges[e] + edges[e + 1])
            for x in range(3):
                if gates_off:
                    seg_gate[e, x] = LOW
                elif e == 0 or x == edge_leg[e] or edges[e + 1] - edges[e] <= tiny:
                    seg_gate[e, x] = _leg_state(middle, t_on[x], t_off[x], dead, compare[x],
                                                counts_top, state[S_HIGH_END + x] != 0.0)
                else:
                    seg_gate[e, x] = seg_gate[e - 1, x]

        j_period = j
        v_integral[:] = 0.0
        # the period average voltage: for wanted rows, or where the last sample may fall
        period_v = need_v or (n_samples > 0 and abs(t_last - t_period - half_period) < 1.5
                              * period)
        tau = 0.0
        f_a, f_b, f_c, k_a, k_b, k_c = evaluate(0.0, omega_e, orders, count, basis)
        _cogging_basis(params, theta_m0, cogging)
        _, torque_a = _shaft_torque(0.0, omega, k_a, k_b, k_c, cur[0], cur[1], cur[2],
                                    n_cogging, cogging)
        y_a = state[S_TR_Y]

        forced_rate = 0.0                             # bound on |d i_e/dτ| (A/s), all phases
        for h in range(count):
            forced_rate += abs(basis[h, B_GAIN]) * orders[h] * abs(omega_e)
        e = -1
        while e < n_edges - 2:
            e += 1
            seg_end = edges[e + 1]
            if seg_end - edges[e] <= tiny:
                continue
            for x in range(3):
                gate[x] = seg_gate[e, x]
            while seg_end - tau > tiny:
                # ---- leg voltages; diodes decide dead legs; zero-current dead legs may clamp
                clamped = 0
                n_float = 0
                for x in range(3):
                    if gate[x] == HIGH:
                        volts[x] = vdc
                    elif gate[x] == LOW:
                        volts[x] = 0.0
                    elif cur[x] > 0.0:
                        volts[x] = 0.0                # lower diode carries positive current
                    elif cur[x] < 0.0:
                        volts[x] = vdc                # upper diode carries negative current
                    else:
                        clamped |= 1 << x
                        n_float += 1
                        volts[x] = 0.5 * vdc
                if gates_off:
                    mode = MODE_ZERO
                elif isolated and n_float >= 2:
                    mode = MODE_ZERO
                else:
                    mode = MODE_FREE
                    for x in range(3):
                        if clamped & (1 << x):
                            kx = (k_a, k_b, k_c)
                            if isolated:
                                m = (x + 1) % 3
                                n = (x + 2) % 3
                                v_float = omega * kx[x] + 0.5 * (volts[m] + volts[n]
                                                                 - omega * (kx[m] + kx[n]))
                            else:
                                v_float = omega * kx[x] + 0.5 * vdc
                            if v_float > vdc:         # diode conducts: current leaves zero
                                volts[x] = vdc
                                clamped &= ~(1 << x)
                            elif v_float < 0.0:
                                volts[x] = 0.0
                                clamped &= ~(1 << x)
                    if isolated and clamped != 0:
                        mode = MODE_ONE_CLAMPED
                k = 0
                for x in range(3):
                    if clamped & (1 << x):
                        k = x
                forced = (f_a, f_b, f_c)
                if mode == MODE_FREE:
                    if isolated:
                        v_mean = (volts[0] + volts[1] + volts[2]) / 3.0
                    else:
                        v_mean = 0.5 * vdc
                    for x in range(3):
                        u[x] = volts[x] - v_mean
                        x0[x] = cur[x] - forced[x]
                elif mode == MODE_ONE_CLAMPED:
                    m = (k + 1) % 3
                    n = (k + 2) % 3
                    u[0] = 0.5 * (volts[m] - volts[n])
                    x0[0] = cur[m] - 0.5 * (forced[m] - forced[n])

                # ---- merge the following segments while every leg keeps its voltage: a dead
                # leg whose current provably keeps its sign (|i| above a bound on its change)
                # acts as the driven state next to it, so no boundary is needed there
                tau_b = seg_end
                e_last = e
                if merge and dead > 0.0 and mode == MODE_FREE and clamped == 0:
                    dead_legs = 0
                    for x in range(3):
                        if gate[x] == DEAD:
                            dead_legs |= 1 << x
                    while e_last < n_edges - 2:
                        same = True
                        for x in range(3):
                            state_x = seg_gate[e_last + 1, x]
                            if state_x == HIGH or (state_x == DEAD and cur[x] < 0.0):
                                level = vdc
                            elif state_x == LOW or (state_x == DEAD and cur[x] > 0.0):
                                level = 0.0
                            else:
                                level = -1.0
                            if level != volts[x]:
                                same = False
                            if state_x == DEAD:
                                dead_legs |= 1 << x
                        if not same:
                            break
                        e_last += 1
                    if e_last > e:
                        span_b = edges[e_last + 1] - tau
                        drift = 1.0 - exp_small(-resistance * span_b / inductance)
                        for x in range(3):
                            if dead_legs & (1 << x):
                                bound = abs(x0[x] - u[x] / resistance) * drift \
                                    + forced_rate * span_b
                                if abs(cur[x]) <= bound:
                                    e_last = e            # might cross zero: no merge
                        if e_last > e:
                            tau_b = edges[e_last + 1]
                fb_a, fb_b, fb_c, kb_a, kb_b, kb_c = evaluate(tau_b, omega_e, orders, count, basis)
                ia, ib, ic = _currents(mode, clamped, k, x0, u, fb_a, fb_b, fb_c,
                                       exp_small(-resistance * (tau_b - tau) / inductance),
                                       resistance)
                crossing = -1
                if mode != MODE_ZERO and e_last == e and (
                        gate[0] == DEAD or gate[1] == DEAD or gate[2] == DEAD):
                    for x in range(3):
                        end_value = (ia, ib, ic)[x]
                        if gate[x] == DEAD and cur[x] != 0.0 and cur[x] * end_value <= 0.0:
                            low = tau
                            high = tau_b
                            for _ in range(BISECTIONS):
                                mid = 0.5 * (low + high)
                                va_, vb_, vc_ = _currents_at(mid, tau, mode, clamped, k, x0, u,
                                                             omega_e, orders, count, basis,
                                                             resistance, inductance)
                                if (va_, vb_, vc_)[x] * cur[x] > 0.0:
                                    low = mid
                                else:
                                    high = mid
                            if crossing < 0 or high < tau_b:
                                tau_b = high
                                crossing = x
                    if crossing >= 0:
                        fb_a, fb_b, fb_c, kb_a, kb_b, kb_c = evaluate(tau_b, omega_e, orders,
                                                                      count, basis)
                        ia, ib, ic = _currents(mode, clamped, k, x0, u, fb_a, fb_b, fb_c,
                                               exp_small(-resistance * (tau_b - tau) / inductance),
                                               resistance)
                _, torque_b = _shaft_torque(tau_b, omega, kb_a, kb_b, kb_c, ia, ib, ic,
                                            n_cogging, cogging)
                span = tau_b - tau
                slope = (torque_b - torque_a) / span

                # ---- the firmware's sampling instant at the counter peak (delay 0.5 / 1.5)
                if peak_pending and tau_b > half_period:
                    peak_a, peak_b, _ = _currents_at(half_period, tau, mode, clamped, k, x0, u,
                                                     omega_e, orders, count, basis, resistance,
                                                     inductance)
                    peak_pending = False

                # ---- samples inside [tau, tau_b): the first one evaluated at its instant, the
                # following ones (equally spaced) by recurrence: decays multiplied by their
                # per-sample factor, harmonic angles rotated by their per-sample step
                first = True
                while j < n_samples:
                    t_sample = record_start_s + j * sample_dt_s
                    tau_s = t_sample - t_period
                    if tau_s >= tau_b:
                        break
                    every = j == last_j           # the last sample: every channel, to ``latest``
                    theta_m = theta_m0 + omega * tau_s
                    if need_filter or every:
                        if first or not need_filter:
                            filter_s = exp_small(-(tau_s - tau) / tau_f)
                        else:
                            filter_s *= filter_step
                        t_filtered = _filter_decayed(y_a, torque_a, slope, tau_s - tau, tau_f,
                                                     filter_s)
                    if need_cur or every:
                        if first or not need_cur:
                            decay_s = exp_small(-resistance * (tau_s - tau) / inductance)
                            for h in range(count):
                                advance[h, 0], advance[h, 1] = sincos_small(orders[h] * omega_e
                                                                            * tau_s)
                        else:
                            if omega_e != step_omega:
                                for h in range(count):
                                    step[h, 0], step[h, 1] = sincos_small(orders[h] * omega_e
                                                                          * sample_dt_s)
                                step_omega = omega_e
                            decay_s *= decay_step
                            advance_by(advance, step, count)
                        fs_a, fs_b, fs_c, ks_a, ks_b, ks_c = evaluate_advanced(advance, count,
                                                                               orders, basis)
                        sa, sb, sc = _currents(mode, clamped, k, x0, u, fs_a, fs_b, fs_c,
                                               decay_s, resistance)
                        if need_torque or every:
                            t_em, t_shaft = _shaft_torque(tau_s, omega, ks_a, ks_b, ks_c, sa,
                                                          sb, sc, n_cogging, cogging)
                        if need_dq or every:
                            s_d = advance[0, 0]                   # the fundamental (order 1)
                            c_d = advance[0, 1]
                            sin_e = sin_e0 * c_d + cos_e0 * s_d
                            cos_e = cos_e0 * c_d - sin_e0 * s_d
                            q_a, q_b, q_c = spread(1, sin_e, cos_e)   # sin(θe − x·2π/3)
                            d_a, d_b, d_c = spread(1, cos_e, -sin_e)  # cos(θe − x·2π/3)
                            i_q = 2.0 / 3.0 * (sa * q_a + sb * q_b + sc * q_c)
                            i_d = 2.0 / 3.0 * (sa * d_a + sb * d_b + sc * d_c)
                    # stores last (after every load of this sample), to rows held in locals
                    if r_time >= 0:
                        out[r_time, j] = t_sample
                    if r_theta >= 0:
                        out[r_theta, j] = theta_m
                    if r_counts >= 0:
                        counts_out[j] = np.int64(encoder_count(theta_m, cpr))
                    if r_speed >= 0:
                        out[r_speed, j] = speed_rpm
                    if r_isa >= 0:
                        out[r_isa, j] = state[S_ISENSE_A]
                    if r_isb >= 0:
                        out[r_isb, j] = state[S_ISENSE_B]
                    if r_filtered >= 0:
                        out[r_filtered, j] = t_filtered
                    if r_ia >= 0:
                        out[r_ia, j] = sa
                    if r_ib >= 0:
                        out[r_ib, j] = sb
                    if r_ic >= 0:
                        out[r_ic, j] = sc
                    if r_em >= 0:
                        out[r_em, j] = t_em
                    if r_shaft >= 0:
                        out[r_shaft, j] = t_shaft
                    if r_iq >= 0:
                        out[r_iq, j] = i_q
                    if r_id >= 0:
                        out[r_id, j] = i_d
                    if every:
                        latest[C_TIME] = t_sample
                        latest[C_THETA_M] = theta_m
                        latest[C_COUNTS] = encoder_count(theta_m, cpr)
                        latest[C_SPEED_RPM] = speed_rpm
                        latest[C_IA_SENSED] = state[S_ISENSE_A]
                        latest[C_IB_SENSED] = state[S_ISENSE_B]
                        latest[C_TORQUE_SHAFT_FILTERED] = t_filtered
                        latest[C_IA] = sa
                        latest[C_IB] = sb
                        latest[C_IC] = sc
                        latest[C_TORQUE_EM] = t_em
                        latest[C_TORQUE_SHAFT] = t_shaft
                        latest[C_IQ] = i_q
                        latest[C_ID] = i_d
                    first = False
                    j += 1

                # ---- line-to-neutral voltage integral (EMF taken at the sub-segment mean)
                if not period_v:
                    n_legs = 0
                elif mode == MODE_FREE and clamped == 0 and isolated:  # the common case
                    shift = (0.5 * omega * (k_a + kb_a + k_b + kb_b + k_c + kb_c)
                             - (volts[0] + volts[1] + volts[2])) / 3.0
                    for x in range(3):
                        v_integral[x] += (volts[x] + shift) * span
                    n_legs = 0
                else:
                    n_legs = 3
                e_mean = (0.5 * omega * (k_a + kb_a), 0.5 * omega * (k_b + kb_b),
                          0.5 * omega * (k_c + kb_c))
                for x in range(n_legs):
                    if mode == MODE_ZERO or clamped & (1 << x):
                        v_xn = e_mean[x]
                    elif mode == MODE_ONE_CLAMPED:
                        m = (k + 1) % 3
                        n = (k + 2) % 3
                        half_diff = 0.5 * (volts[m] - volts[n])
                        common = 0.5 * (e_mean[m] + e_mean[n])
                        v_xn = common + (half_diff if x == m else -half_diff)
                    elif isolated:
                        v_xn = volts[x] - (volts[0] + volts[1] + volts[2]) / 3.0 \
                            + (e_mean[0] + e_mean[1] + e_mean[2]) / 3.0
                    else:
                        v_xn = volts[x] - 0.5 * vdc
                    v_integral[x] += v_xn * span

                # ---- move to tau_b
                y_a = _filter(y_a, torque_a, slope, span, tau_f)
                cur[0] = ia
                cur[1] = ib
                cur[2] = ic
                if crossing >= 0:
                    residual = cur[crossing]
                    cur[crossing] = 0.0
                    if mode == MODE_ONE_CLAMPED:
                        cur[:] = 0.0                  # the pair crosses together
                    elif isolated:
                        cur[(crossing + 1) % 3] += 0.5 * residual
                        cur[(crossing + 2) % 3] += 0.5 * residual
                tau = tau_b
                if e_last > e:                        # continue after the merged segments
                    e = e_last
                    seg_end = edges[e + 1]
                    for x in range(3):
                        gate[x] = seg_gate[e, x]
                torque_a = torque_b
                f_a = fb_a
                f_b = fb_b
                f_c = fb_c
                k_a = kb_a
                k_b = kb_b
                k_c = kb_c

        if period_v:
            for x in range(3):
                v_mean = v_integral[x] / period
                if rows[C_VA + x] >= 0:
                    out[rows[C_VA + x], j_period:j] = v_mean
                if j_period <= last_j < j:
                    latest[C_VA + x] = v_mean
        if enabled and mid_sampling:                  # sampled at the peak, applied at the
            ca, cb, cc = firmware_step(peak_a, peak_b, theta_m0 + omega * half_period, omega,
                                       params, state, counts_top, constants,
                                       angle_cache)  # next valley (0.5) or the one after (1.5)
            if params[P_LOOP_DELAY] > 1.0:
                for x in range(3):
                    state[S_CMP_A + x] = state[S_CMP_PENDING + x]
            state[S_CMP_PENDING] = ca
            state[S_CMP_PENDING + 1] = cb
            state[S_CMP_PENDING + 2] = cc
            if params[P_LOOP_DELAY] < 1.0:
                for x in range(3):
                    state[S_CMP_A + x] = state[S_CMP_PENDING + x]
        for x in range(3):
            state[S_HIGH_END + x] = 1.0 if compare[x] >= counts_top else 0.0
        state[S_IA] = cur[0]
        state[S_IB] = cur[1]
        state[S_IC] = cur[2]
        state[S_TR_Y] = y_a
        state[S_THETA_M] = theta_m0 + omega * period
        state[S_TIME] = t_period + period
    return committed


@njit(cache=True, error_model="numpy", fastmath=False, parallel=True, nogil=True)
def run_batch(params, states, record_start_s, sample_dt_s, outs, rows, latest, end_s):
    """``run_drive`` for many parameter sets (rows) in parallel over all cores."""
    for b in prange(params.shape[0]):
        run_drive(params[b], states[b], record_start_s, sample_dt_s, outs[b], rows, latest[b],
                  end_s)
