"""Controller firmware of the drive: sensing, position, FOC current loop, modulator (compiled).

Executed once per PWM period at the counter valley (period start): the two phase currents are
sampled through the ADC (with the injected offset/gain, eqs 15-16 and 21-22), the third is computed
(eq 17), the rotor angle is read from the encoder (decimated, or Hall 60° sectors: the angle the
paper calls θ_d, eq 4), Park (eq 11, three-phase form with a sine table), two PI regulators with
anti-windup, inverse Park, zero-sequence injection and the compare values. By default the result
is latched for the *next* period: one period of computation delay (the engine also runs it with
0, 0.5 or 1.5 periods, see ``hil.sim.kernel``). Optional parts of the loop (``FirmwareModel``):
decoupling of the dq cross terms, back-EMF feed-forward and an inverse-Park angle advanced by
ωe × (loop delay) to compensate the rotation during the delay.

Arithmetic is float64, or n-bit fixed point when ``word_length_bits`` > 0: every stored value is a
signed Q(n-1) fraction of its base (currents: the ADC full scale; voltages: the dc bus) and every
product and sum is truncated toward -inf as a two's-complement DSP does (the error model of eqs
12-14). Gains larger than one are stored as an n-bit mantissa with a power-of-two shift.

Every function here is compiled with ``fastmath=False`` stated explicitly, so its arithmetic is
IEEE-exact however it is compiled: numba lets a function that does not state ``fastmath`` inherit
the flags of the (fast-math) engine it is first compiled inside, which made truncation decisions
depend on which function happened to be compiled first.
"""

from __future__ import annotations

import math

import numpy as np

from numba import njit

from hil.sim.layout import (P_ADC_BITS, P_ADC_FS, P_ANGLE_ADVANCE, P_DEAD_TIME, P_DECOUPLE_PU,
                            P_EMF_FF_PU, P_ENC_CPR, P_ENC_DECIM, P_HALL, P_IA_GAIN, P_IA_OFFSET,
                            P_IB_GAIN, P_IB_OFFSET, P_ID_CMD, P_IQ_CMD, P_KI_TS_PU, P_KP_PU,
                            P_TEST_AMP_PU, P_TEST_ORDER,
                            P_MODULATION, P_POLE_PAIRS, P_PWM_COUNTS, P_PWM_FREQ, P_TABLE_SIZE,
                            P_WORD_BITS, S_INT_D, S_INT_Q, S_ISENSE_A, S_ISENSE_B)

TWO_PI = 2.0 * math.pi
SIN_120 = math.sqrt(3.0) / 2.0


@njit(cache=True, error_model="numpy", fastmath=False)
def qfix(x, lsb):
    """Truncate ``x`` (per unit) to a saturating signed fraction of resolution ``lsb``
    (2^(1-n) for an n-bit word, see ``word_lsb``); lsb 0 = floating point, unchanged."""
    return _qfix(x, (lsb, 1.0 / lsb if lsb != 0.0 else 0.0))


@njit(cache=True, error_model="numpy", fastmath=False)
def _qfix(x, word):
    """``qfix`` given word = (lsb, 1/lsb) (the firmware's per-run ``K_LSB``, ``K_SCALE``: no
    division per truncation; the same bits, since 1/lsb is an exact power of two)."""
    lsb, scale = word
    if lsb == 0.0:
        return x
    # exact: lsb is a power of two. np.floor stays in float64 (one rounding instruction);
    # math.floor would go through int64 and back, the same value at twice the latency
    y = np.floor(x * scale) * lsb
    if y > 1.0 - lsb:
        return 1.0 - lsb
    if y < -1.0:
        return -1.0
    return y


def word_lsb(bits: int) -> float:
    """Resolution of a signed Q(n-1) fraction of an n-bit word; 0 for floating point (n = 0)."""
    return 0.0 if bits == 0 else 2.0 ** (1 - bits)


def quantise_gain(gain: float, bits: int) -> float:
    """A gain as the firmware stores it: n-bit mantissa (truncated) times a power of two."""
    if bits == 0 or gain == 0.0:
        return gain
    exponent = math.ceil(math.log2(abs(gain))) if abs(gain) >= 1.0 else 0
    lsb = 2.0 ** (1 - bits)
    return math.floor(gain / 2.0 ** exponent / lsb) * lsb * 2.0 ** exponent


#: per-run constants of the firmware (``firmware_constants``): word resolution (``word_lsb``),
#: ADC half range 2^(bits − 1), largest compare value (counts), the current references (per
#: unit, stored), 2/3 as stored (eq 11), the voltage limit (per unit of V_dc), 1 for SVPWM;
#: reciprocals (exact powers of two, or only used where ``_modulo_by`` corrects the quotient):
#: 1/lsb, 1/encoder counts per rev, 1/decimation, 1/sine-table size
K_LSB, K_ADC_HALF, K_MAX_COMPARE, K_IQ_REF, K_ID_REF, K_TWO_THIRDS, K_LIMIT, K_SVPWM, K_SCALE, \
    K_INV_CPR, K_INV_DECIMATION, K_INV_TABLE = range(12)
N_FIRMWARE_CONSTANTS = 12


@njit(cache=True, error_model="numpy", fastmath=False)
def firmware_constants(params):
    """The firmware's constants of one run (``K_*`` indices), each computed by the same float64
    expression the loop used to evaluate every period (so the loop's results are bit-identical).

    ``K_MAX_COMPARE``: the largest compare value whose pulse still ends a dead time before the
    period end; wider pulses are dropped to full-on (see ``_compare``): no dead time.
    """
    constants = np.empty(N_FIRMWARE_CONSTANTS)
    bits = params[P_WORD_BITS]
    lsb = 0.0 if bits == 0.0 else 2.0 ** (1.0 - bits)
    constants[K_LSB] = lsb
    constants[K_ADC_HALF] = 2.0 ** (params[P_ADC_BITS] - 1.0)
    counts_top = params[P_PWM_COUNTS]
    dead = params[P_DEAD_TIME]
    max_compare = counts_top
    if dead > 0.0:
        period = 1.0 / params[P_PWM_FREQ]
        max_compare = float(np.floor(counts_top * (1.0 - 2.0 * dead / period)))
    constants[K_MAX_COMPARE] = max_compare
    full_scale = params[P_ADC_FS]
    constants[K_IQ_REF] = qfix(params[P_IQ_CMD] / full_scale, lsb)  # lags the EMF by φ, eq (4)
    constants[K_ID_REF] = qfix(params[P_ID_CMD] / full_scale, lsb)
    constants[K_TWO_THIRDS] = qfix(2.0 / 3.0, lsb)
    svpwm = params[P_MODULATION] == 0.0
    constants[K_LIMIT] = 1.0 / math.sqrt(3.0) if svpwm else 0.5  # linear range, pu of V_dc
    constants[K_SVPWM] = 1.0 if svpwm else 0.0
    constants[K_SCALE] = 1.0 / lsb if lsb != 0.0 else 0.0
    constants[K_INV_CPR] = 1.0 / params[P_ENC_CPR]
    constants[K_INV_DECIMATION] = 1.0 / params[P_ENC_DECIM]
    constants[K_INV_TABLE] = 1.0 / params[P_TABLE_SIZE]
    return constants


@njit(cache=True, error_model="numpy", fastmath=False)
def encoder_count(theta_m, cpr):
    """Encoder position (counts, truncated toward −inf) of the mechanical angle ``theta_m``."""
    return np.floor(theta_m * cpr / TWO_PI)


@njit(cache=True, error_model="numpy", fastmath=False)
def adc_read(current_a, offset_a, gain_error_pu, full_scale_a, half):
    """Sensor (gain, offset) then an ADC of 2·``half`` codes over ±full scale; per unit of FS.

    Ideal mid-tread converter (transitions half an LSB either side of each code), so zero
    current reads zero: the ADC adds quantisation but no offset of its own.
    """
    sensed = (1.0 + gain_error_pu) * current_a + offset_a
    code = np.floor((sensed / full_scale_a + 1.0) * half + 0.5)
    if code < 0.0:
        code = 0.0
    elif code > 2.0 * half - 1.0:
        code = 2.0 * half - 1.0
    return (code - half) * (1.0 / half)                  # exact: half is a power of two


@njit(cache=True, error_model="numpy", fastmath=False)
def _modulo(value, modulus):
    """``value % modulus`` (Python sign convention) for integer-valued floats, |value| < 2^53 and
    modulus > 0: exact, and cheaper than the library fmod."""
    return _modulo_by(value, modulus, 1.0 / modulus)


@njit(cache=True, error_model="numpy", fastmath=False)
def _modulo_by(value, modulus, inverse):
    """``_modulo`` given inverse ≈ 1/modulus (no division). The same exact result: the quotient
    floor(value·inverse) is off by at most one, so value − quotient·modulus (exact for
    integer-valued floats below 2^53) is off by at most one modulus, which the steps correct."""
    remainder = value - np.floor(value * inverse) * modulus
    if remainder < 0.0:
        remainder += modulus
    elif remainder >= modulus:
        remainder -= modulus
    return remainder


@njit(cache=True, error_model="numpy", fastmath=False)
def firmware_angle_fraction(theta_m, params, constants):
    """The firmware's electrical angle as a fraction of a revolution (θ_d of eq 4).

    Encoder: counts truncated to a multiple of the decimation factor (counts − counts mod
    decimation: floor(counts/decimation)·decimation exactly, below 2^52 counts); Hall: start of
    the 60° electrical sector. Count 0 is aligned with θe = 0.
    """
    pole_pairs = params[P_POLE_PAIRS]
    if params[P_HALL] != 0.0:
        sector = np.floor(pole_pairs * theta_m / (math.pi / 3.0))
        return _modulo_by(sector, 6.0, 1.0 / 6.0) / 6.0
    cpr = params[P_ENC_CPR]
    counts = encoder_count(theta_m, cpr)
    decimation = params[P_ENC_DECIM]
    used = counts - _modulo_by(counts, decimation, constants[K_INV_DECIMATION])
    return _modulo_by(used * pole_pairs, cpr, constants[K_INV_CPR]) / cpr


@njit(cache=True, error_model="numpy", fastmath=False)
def _pi_axis(reference, measured, integrator, kp, ki_ts, limit, word, feedforward):
    """One PI step plus ``feedforward`` with conditional integration (anti-windup: the
    integrator holds while the total output is saturated and the error pushes further);
    returns (output, integrator)."""
    error = _qfix(reference - measured, word)
    proportional = _qfix(kp * error, word)
    candidate = _qfix(integrator + _qfix(ki_ts * error, word), word)
    if candidate > limit:
        candidate = limit
    elif candidate < -limit:
        candidate = -limit
    unsaturated = proportional + candidate
    if feedforward != 0.0:
        unsaturated += feedforward
    if abs(unsaturated) > limit and unsaturated * error > 0.0:
        candidate = integrator          # saturated and the error pushes further: hold
        unsaturated = proportional + candidate
        if feedforward != 0.0:
            unsaturated += feedforward
    output = _qfix(unsaturated, word)
    if output > limit:
        output = limit
    elif output < -limit:
        output = -limit
    return output, candidate


#: rows of the firmware's angle cache (direct-mapped on the sine-table index; a power of two)
ANGLE_CACHE_ROWS = 4096
A_INDEX, A_SIN_A, A_COS_A, A_SIN_B, A_SIN_C, A_COS_B, A_COS_C = range(7)


@njit(cache=True, error_model="numpy", fastmath=False)
def angle_values(index, table_size, word, cache):
    """The sine-table entries of ``index`` and the other phases' values derived from them.

    Remembered in ``cache`` (row = index modulo its size; column 0 holds the index or -1), so
    each is computed once per run; values are identical either way.
    """
    row = int(index) & (cache.shape[0] - 1)
    if cache[row, A_INDEX] != index:
        angle = TWO_PI * index / table_size
        s_a = _qfix(math.sin(angle), word)                        # table entries
        c_a = _qfix(math.cos(angle), word)
        half = _qfix(0.5, word)                                   # other phases by identities
        root3_2 = _qfix(SIN_120, word)
        cache[row, A_SIN_A] = s_a
        cache[row, A_COS_A] = c_a
        cache[row, A_SIN_B] = _qfix(-_qfix(half * s_a, word) - _qfix(root3_2 * c_a, word), word)
        cache[row, A_SIN_C] = _qfix(-_qfix(half * s_a, word) + _qfix(root3_2 * c_a, word), word)
        cache[row, A_COS_B] = _qfix(-_qfix(half * c_a, word) + _qfix(root3_2 * s_a, word), word)
        cache[row, A_COS_C] = _qfix(-_qfix(half * c_a, word) - _qfix(root3_2 * s_a, word), word)
        cache[row, A_INDEX] = index
    return (cache[row, A_SIN_A], cache[row, A_COS_A], cache[row, A_SIN_B], cache[row, A_SIN_C],
            cache[row, A_COS_B], cache[row, A_COS_C])


@njit(cache=True, error_model="numpy", fastmath=False)
def firmware_step(ia_a, ib_a, theta_m, omega_m, params, state, counts_top, constants,
                  angle_cache):
    """Run the current loop once; return the compare values (counts) it computes.

    ``omega_m``: the rotor speed, rad/s (an ideal speed estimate; only the decoupling, the EMF
    feed-forward and the angle compensation use it). ``constants``: ``firmware_constants``;
    ``angle_cache``: ``ANGLE_CACHE_ROWS`` × 7, column ``A_INDEX`` set to -1, for one run at
    one word length.
    """
    word = (constants[K_LSB], constants[K_SCALE])          # resolution and its reciprocal
    adc_half = constants[K_ADC_HALF]
    full_scale = params[P_ADC_FS]
    sensed_a = adc_read(ia_a, params[P_IA_OFFSET], params[P_IA_GAIN], full_scale, adc_half)
    sensed_b = adc_read(ib_a, params[P_IB_OFFSET], params[P_IB_GAIN], full_scale, adc_half)
    state[S_ISENSE_A] = sensed_a * full_scale
    state[S_ISENSE_B] = sensed_b * full_scale
    i_a = _qfix(sensed_a, word)
    i_b = _qfix(sensed_b, word)
    i_c = _qfix(-i_a - i_b, word)                                 # eq (17)

    table_size = params[P_TABLE_SIZE]
    fraction = firmware_angle_fraction(theta_m, params, constants)
    index = _modulo_by(np.floor(fraction * table_size), table_size, constants[K_INV_TABLE])
    s_a, c_a, s_b, s_c, c_b, c_c = angle_values(index, table_size, word, angle_cache)

    two_thirds = constants[K_TWO_THIRDS]                          # eq (11)
    i_q = _qfix(two_thirds * (_qfix(i_a * s_a, word) + _qfix(i_b * s_b, word)
                              + _qfix(i_c * s_c, word)), word)
    i_d = _qfix(two_thirds * (_qfix(i_a * c_a, word) + _qfix(i_b * c_b, word)
                              + _qfix(i_c * c_c, word)), word)

    i_q_ref = constants[K_IQ_REF]
    if params[P_TEST_AMP_PU] != 0.0:                              # the loop's test signal
        i_q_ref = _qfix(i_q_ref + _qfix(params[P_TEST_AMP_PU] * math.sin(
            TWO_PI * params[P_TEST_ORDER] * fraction), word), word)
    i_d_ref = constants[K_ID_REF]
    limit = constants[K_LIMIT]
    kp = params[P_KP_PU]
    ki_ts = params[P_KI_TS_PU]
    # feed-forward of the motor's dq equations in this frame (q along the EMF, e_a = E·sin θe):
    # v_q = R·i_q + L·di_q/dt − ωe·L·i_d + E,  v_d = R·i_d + L·di_d/dt + ωe·L·i_q
    ff_d = 0.0
    ff_q = 0.0
    if params[P_DECOUPLE_PU] != 0.0:
        w_l = _qfix(omega_m * params[P_DECOUPLE_PU], word)        # ωe·L, per unit
        ff_d = _qfix(w_l * i_q, word)
        ff_q = _qfix(-(w_l * i_d), word)
    if params[P_EMF_FF_PU] != 0.0:
        ff_q = _qfix(ff_q + _qfix(omega_m * params[P_EMF_FF_PU], word), word)   # + E, per unit
    v_d, state[S_INT_D] = _pi_axis(i_d_ref, i_d, state[S_INT_D], kp, ki_ts, limit, word, ff_d)
    v_q, state[S_INT_Q] = _pi_axis(i_q_ref, i_q, state[S_INT_Q], kp, ki_ts, limit, word, ff_q)
    magnitude = math.sqrt(v_d * v_d + v_q * v_q)
    if magnitude > limit:
        v_d = _qfix(v_d * limit / magnitude, word)
        v_q = _qfix(v_q * limit / magnitude, word)

    if params[P_ANGLE_ADVANCE] != 0.0:      # rotate the output by the angle turned meanwhile
        shift = np.floor(omega_m * params[P_POLE_PAIRS] * params[P_ANGLE_ADVANCE] / TWO_PI
                           * table_size + 0.5)
        shifted = _modulo_by(index + shift, table_size, constants[K_INV_TABLE])
        s_a, c_a, s_b, s_c, c_b, c_c = angle_values(shifted, table_size, word, angle_cache)

    v_a = _qfix(_qfix(v_q * s_a, word) + _qfix(v_d * c_a, word), word)  # inverse Park
    v_b = _qfix(_qfix(v_q * s_b, word) + _qfix(v_d * c_b, word), word)
    v_c = _qfix(_qfix(v_q * s_c, word) + _qfix(v_d * c_c, word), word)
    zero_sequence = 0.0
    if constants[K_SVPWM] != 0.0:
        zero_sequence = -0.5 * (max(v_a, v_b, v_c) + min(v_a, v_b, v_c))
    max_compare = constants[K_MAX_COMPARE]
    return (_compare(v_a + zero_sequence, counts_top, max_compare),
            _compare(v_b + zero_sequence, counts_top, max_compare),
            _compare(v_c + zero_sequence, counts_top, max_compare))


@njit(cache=True, error_model="numpy", fastmath=False)
def _compare(leg_voltage_pu, counts_top, max_compare):
    """Compare value (integer counts, truncated) for a leg voltage in per unit of V_dc.

    Pulses too wide to fit a dead time before the period end (above ``max_compare``) are
    rounded to the nearer of ``max_compare`` and full-on (pulse dropping).
    """
    compare = np.floor((0.5 + leg_voltage_pu) * counts_top)
    if compare < 0.0:
        return 0.0
    if compare > max_compare:
        if compare >= counts_top or compare >= 0.5 * (max_compare + counts_top):
            return counts_top
        return max_compare
    return compare
