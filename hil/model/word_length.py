"""Finite CPU word length (paper section III-B, eqs 10-14 and the pk-pk bound).

An n-bit fixed-point controller stores per-unit values (full scale I_max) with a truncation error
below one LSB, 1/2^(n−1). The q-axis current of the Park transform (eq 10, with i_a = I·sin θ the
projection is (2/3)·Σ I_x·sin(θ_x), see the README's typo list) is built from three truncated
currents and three truncated trigonometric values; to first order (eq 12)

    ΔI_q = (2/3)·Σ_x [ΔI_x·s_x + I_x·Δs_x]          (s_x the sin/cos table value)

so |ΔI_q| ≤ (2/3)·6/2^(n−1) = 4/2^(n−1) (eq 13), plus the truncation of the result: 5/2^(n−1)
(eq 14). Ideal regulation turns ΔI_q into an actual current error I_max·ΔI_q, of either sign, so
the torque pk-pk bound is 10/2^(n−1) per unit of the torque at I_max. Per unit of the mean torque
at the operating point (peak current I, angle φ) it is 10/2^(n−1)·I_max/(I·cos φ).

That bound is one-sided: a drive that ignores the injection meets it. ``model="derived"`` (not in
the paper) gives a two-sided expectation from the *bias* of two's-complement truncation (toward
−∞): a value spread over many LSBs loses on average half the difference between the word's LSB
L = 2^(1−n) and the grid it was on. Three terms, per unit of the mean torque (ideal regulation of
the computed I_q, so the actual I_q error is minus the computed one; the loop follows an order-1
error since ω_e ≪ ω_c):

1. **Current readings** (order 1): ADC codes (grid L_adc = 2^(1−adc_bits) of I_max) truncated to
   the word read low by β = ½·(L − L_adc)·I_max on both sensors (zero when the word is at least as
   fine as the ADC): the dc offset of eq 20, phasor (2/3)·Σ_x err_x·e^(−j·o_x) with
   err = (−β, −β, +2β) (i_c computed, eq 17), magnitude 2β.
2. **Trigonometric values** (order 1): with ``trig_values="identities"`` (sin θ and cos θ from a
   table, the other phases by sin(θ ∓ 2π/3) = −½·sin θ ∓ (√3/2)·cos θ, each product truncated:
   the simulated drive's firmware) the three sines carry biases b = (−½, 1 + r/2, −r/2)·L,
   r = √3/2 truncated; their phasor (2/3)·I·e^(−jφ)·Σ_x b_x·e^(−j·o_x) adds to term 1.
   ``trig_values="tables"`` (one truncated table entry per phase): equal biases, no ripple.
   Pk-pk of terms 1 + 2: 2·|phasor|/(I·cos φ).
3. **Broadband**: the fluctuating parts of the same truncations (sensor readings, trigonometric
   values, the three Park products and the result, each uniform over [0, L)) give the computed
   I_q an error of standard deviation σ = L·I_max·sqrt(1/9 + 1/9 + 1/12 + (I/I_max)²/18)
   (sensors through (2/3)·Σ err_x·s_x with err_c = −err_a − err_b, products, result, table).
   Sampled once per PWM period, N = f_pwm/f_e times per electrical revolution, it repeats every
   revolution when N is whole (synchronous: averaging does not reduce it); the analysis keeps
   orders 1..K, i.e. a share K/(N/2) of its power: σ_K = σ·sqrt(min(1, 2K/N)). Were it all
   synchronous, its pk-pk over the 2K independent values of a band-limited revolution would be
   B = 2·σ_K·sqrt(2·ln(2K)), per unit of I·cos φ. Part of it changes from one revolution to the
   next (the loop's integrator dithers the truncations) and the synchronous average removes that
   part; the split is not modelled, so term 3 is taken as B/2, between 0 and B.

**Loop and transducer** (``current_loop_bandwidth_hz``, ``current_loop_delay_s``,
``transducer_bandwidth_hz``; issue 21): all three terms are errors of the *computed* I_q, so the
actual current error is the computed one through the loop's measurement→current response
T = C·P·d/(1 + C·P·d) (PI with Kp = ω_c·L, Ki = ω_c·R, the delay d = e^(−(s + jω_e)·τ), the
plant 1/(R + L·(s + jω_e)) in the rotor frame, as ``hil.model.dead_time.loop_rejection``),
read on the q axis: G(ω) = (T(ω) + conj T(−ω))/2; and the bench sees the torque through the
stated first-order transducer H. Term 1 + 2 at order 1 is multiplied by |G·H| at ω_e; term 3's
power by the mean of |G·H|² over the orders it keeps: share = (2·f_e/f_pwm)·Σ_k |G·H|²(k·f_e),
k = 1..K below f_pwm/2 (without a loop or transducer stated, G = H = 1 and the share is
min(1, 2K·f_e/f_pwm) as before). Where the band K·f_e lies far above the loop's bandwidth
(8-pole motor at 2475 rpm: f_e = 165 Hz, orders ≤ 48 reach 7.9 kHz against a 1.6 kHz loop and a
1 kHz transducer) the loop does not follow the fast part of the truncation noise and the
transducer does not pass it: the ideal-regulation term 3 was 0.058 pu there, the twin's
broadband part ≈ 0.01 pu, and the model read 1.6-1.8× the measured pk-pk.

Value: 1 + 2 + 3; expected range: terms 1 + 2 within ±20 % (the uniform-bias assumption) plus
term 3 between 0 and B. Not modelled (inside the range): the mean-torque shift of
the truncated reference and of the integrator's truncation bias (a few % at 8 bits), the
second-order error of the truncated √3/2 (an order-2 term below one LSB), the reduction of the
broadband part by averaging when N is not whole. The drive's own ripple floor (the baseline) is
not included.
"""

from __future__ import annotations

import cmath
import math

import numpy as np

from hil.current_loop import PI_DESIGNS
from hil.errors import InputError
from hil.model.core import (MEAN_TORQUE_BASE, PHASE_OFFSETS_RAD, OperatingPoint, Prediction,
                            check_range)

#: Q-format full scale of the current: the ADC range of the contract, ±100 A.
FULL_SCALE_CURRENT_A = 100.0
#: The stated loop designs this model represents: a PI (the discrete one by its equivalent
#: bandwidth, ``hil.current_loop``); ``hil.validity`` refuses a point on another.
REPRESENTED_LOOP_DESIGNS = PI_DESIGNS
WORD_LENGTH_RANGE_BITS = (6, 32)
#: The drive's current ADC (the simulated drive: 12 bits over ±I_max).
ADC_BITS = 12
MODELS = ("paper", "derived")
TRIG_VALUES = ("identities", "tables")
#: Relative uncertainty of the order-1 bias terms (uniformly spread truncation errors assumed).
BIAS_TERM_REL_UNCERTAINTY = 0.2
#: The broadband term's expected range: 0 to this many times its value (0 to B).
BROADBAND_HIGH_FACTOR = 2.0
#: Highest electrical order the analysis keeps by default (hil.analysis DEFAULT_MAX_ORDER).
DEFAULT_MAX_ORDER = 64


def lsb_pu(word_length_bits: int) -> float:
    """One LSB of a signed n-bit per-unit number: 1/2^(n−1)."""
    return 1.0 / 2.0 ** (word_length_bits - 1)


def iq_error_bound_pu(word_length_bits: int) -> float:
    """Eq 14: |ΔI_q| ≤ 5/2^(n−1) (accumulation 4/2^(n−1), eq 13, plus the result's truncation)."""
    return 5.0 * lsb_pu(word_length_bits)


def paper_pk_pk_pu(word_length_bits: int) -> float:
    """The paper's bound 10/2^(n−1), per unit of the torque at the full-scale current I_max."""
    return 2.0 * iq_error_bound_pu(word_length_bits)


def balanced_pk_pk_pu(word_length_bits: int, current_pu: float) -> float:
    """A tighter first-order pk-pk for balanced three-phase signals, per unit of I_max torque.

    Σ|sin θ_x| ≤ 2 and Σ|I_x| ≤ 2·I/I_max for a balanced set, so eq 13's 6 terms become
    2 + 2·I/I_max: |ΔI_q| ≤ [1 + (2/3)·(2 + 2·I/I_max)]/2^(n−1) (at most 11/3 LSB, not 5).
    """
    return 2.0 * lsb_pu(word_length_bits) * (1.0 + (2.0 / 3.0) * (2.0 + 2.0 * current_pu))


def check_bits(word_length_bits: int) -> int:
    bits = check_range("word_length_bits", word_length_bits, *WORD_LENGTH_RANGE_BITS, unit=" bits")
    if bits != int(bits):
        raise InputError(f"word_length_bits={word_length_bits!r} is not an integer "
                         f"(allowed {WORD_LENGTH_RANGE_BITS[0]}..{WORD_LENGTH_RANGE_BITS[1]} bits)")
    return int(bits)


def sensor_bias_a(word_length_bits: int, adc_bits: int, full_scale_current_a: float) -> float:
    """β: mean amount by which a current reading truncated to the word reads low, amperes."""
    return 0.5 * max(lsb_pu(word_length_bits) - lsb_pu(adc_bits), 0.0) * full_scale_current_a


def trig_biases_lsb(trig_values: str) -> tuple[float, float, float]:
    """Mean truncation biases of sin(θ − o_x) for phases a, b, c, in LSB (module docstring)."""
    if trig_values == "tables":
        return (-0.5, -0.5, -0.5)
    root3_2 = math.sqrt(3.0) / 2.0  # its truncation changes the bias by < 1e-2 LSB at 8 bits
    return (-0.5, 1.0 + root3_2 / 2.0, -root3_2 / 2.0)


def order1_phasor_a(op: OperatingPoint, word_length_bits: int, adc_bits: int,
                    full_scale_current_a: float, trig_values: str) -> complex:
    """Phasor of the computed-I_q error at order 1 (terms 1 + 2 of the docstring), amperes."""
    beta = sensor_bias_a(word_length_bits, adc_bits, full_scale_current_a)
    rotations = [cmath.exp(-1j * offset) for offset in PHASE_OFFSETS_RAD]
    sensors = (2.0 / 3.0) * sum(err * rot for err, rot in zip((-beta, -beta, 2 * beta), rotations))
    lsb_a = lsb_pu(word_length_bits)
    trig = (2.0 / 3.0) * op.current_a * cmath.exp(-1j * op.current_angle_rad) * lsb_a * sum(
        b * rot for b, rot in zip(trig_biases_lsb(trig_values), rotations))
    return sensors + trig


def truncation_noise_std_a(word_length_bits: int, current_a: float,
                           full_scale_current_a: float) -> float:
    """σ of the computed I_q's fluctuating truncation error, amperes (term 3 of the docstring)."""
    ratio = current_a / full_scale_current_a
    return lsb_pu(word_length_bits) * full_scale_current_a * math.sqrt(
        1 / 9 + 1 / 9 + 1 / 12 + ratio * ratio / 18)


def q_axis_measurement_response(frequency_hz: np.ndarray, op: OperatingPoint,
                                current_loop_bandwidth_hz: float | None,
                                current_loop_delay_s: float = 0.0) -> np.ndarray:
    """G(ω): an error of the computed I_q at ``frequency_hz`` (rotor frame) → actual I_q error,
    magnitude and phase (module docstring, "Loop and transducer"); 1 without a loop stated
    (ideal regulation). The plant is ``op.motor``, the PI's gains those of ``op.loop_motor``
    (the motor the drive was tuned on)."""
    f = np.asarray(frequency_hz, dtype=float)
    if not current_loop_bandwidth_hz:
        return np.ones_like(f, dtype=complex)
    motor, tuned = op.motor, op.loop_motor
    wc = 2.0 * math.pi * current_loop_bandwidth_hz
    we = op.elec_speed_rad_s

    def tracking(s):
        plant = 1.0 / (motor.phase_resistance_ohm + motor.phase_inductance_h * (s + 1j * we))
        controller = wc * (tuned.phase_resistance_ohm + tuned.phase_inductance_h * s) / s
        loop = controller * plant * np.exp(-(s + 1j * we) * current_loop_delay_s)
        return loop / (1.0 + loop)

    s = 2j * math.pi * np.where(f == 0.0, 1e-9, f)
    return 0.5 * (tracking(s) + np.conj(tracking(-s)))


def derived_terms_pu(op: OperatingPoint, word_length_bits: int, *, adc_bits: int = ADC_BITS,
                     full_scale_current_a: float = FULL_SCALE_CURRENT_A,
                     trig_values: str = "identities", pwm_frequency_hz: float = 20000.0,
                     max_order: int = DEFAULT_MAX_ORDER,
                     current_loop_bandwidth_hz: float | None = None,
                     current_loop_delay_s: float = 0.0,
                     transducer_bandwidth_hz: float | None = None) -> dict[str, float]:
    """The derived model's terms, per unit of the mean torque (module docstring)."""
    from hil.model.dead_time import transducer_response

    active_a = op.current_a * math.cos(op.current_angle_rad)
    elec_hz = abs(op.elec_speed_rad_s) / (2.0 * math.pi)

    def seen(frequency_hz):
        """|G·H|: computed-I_q error → the torque the bench reads (module docstring)."""
        return np.abs(q_axis_measurement_response(frequency_hz, op, current_loop_bandwidth_hz,
                                                  current_loop_delay_s)
                      * transducer_response(frequency_hz, transducer_bandwidth_hz))

    order1 = 2.0 * abs(order1_phasor_a(op, word_length_bits, adc_bits, full_scale_current_a,
                                       trig_values)) / active_a * float(seen(elec_hz))
    sigma = truncation_noise_std_a(word_length_bits, op.current_a, full_scale_current_a)
    share = 0.0
    if elec_hz > 0.0:
        kept = np.arange(1, max_order + 1)
        kept = kept[kept * elec_hz <= pwm_frequency_hz / 2.0]
        share = min(1.0, 2.0 * elec_hz / pwm_frequency_hz * float(
            np.sum(seen(kept * elec_hz) ** 2)))
    sigma_band = sigma * math.sqrt(share)
    all_synchronous = 2.0 * sigma_band * math.sqrt(2.0 * math.log(2.0 * max_order)) / active_a
    broadband = 0.5 * all_synchronous  # the synchronous share is not modelled: midpoint
    # order 1 dominates the spectrum when its amplitude beats 3× the broadband rms per order
    per_order_rms = sigma_band * math.sqrt(2.0 / max_order) / active_a
    return {"order1_pk_pk_pu": order1, "broadband_pk_pk_pu": broadband,
            "pk_pk_pu": order1 + broadband,
            "low_pu": (1.0 - BIAS_TERM_REL_UNCERTAINTY) * order1,
            "high_pu": (1.0 + BIAS_TERM_REL_UNCERTAINTY) * order1
            + BROADBAND_HIGH_FACTOR * broadband,
            "order1_dominant": order1 / 2.0 > 3.0 * per_order_rms,
            "sensor_bias_a": sensor_bias_a(word_length_bits, adc_bits, full_scale_current_a),
            "truncation_noise_std_a": sigma}


def predict_word_length(op: OperatingPoint, *, word_length_bits: int,
                        full_scale_current_a: float = FULL_SCALE_CURRENT_A,
                        model: str = "paper", adc_bits: int = ADC_BITS,
                        trig_values: str = "identities", pwm_frequency_hz: float = 20000.0,
                        max_order: int = DEFAULT_MAX_ORDER,
                        current_loop_bandwidth_hz: float | None = None,
                        current_loop_delay_s: float = 0.0,
                        transducer_bandwidth_hz: float | None = None) -> Prediction:
    """Worst-case broadband ripple bound of an n-bit controller (the paper), or with
    ``model="derived"`` the two-sided expectation from truncation bias; per unit of the mean
    torque."""
    bits = check_bits(word_length_bits)
    i_max = check_range("full_scale_current_a", full_scale_current_a, 0.0, 1e4, unit=" A",
                        low_open=True)
    if model not in MODELS:
        raise InputError(f"model={model!r} is not one of {', '.join(MODELS)}")
    paper = paper_pk_pk_pu(bits)
    scale = i_max / (op.current_a * math.cos(op.current_angle_rad))
    if model == "derived":
        return _derived_prediction(op, bits, i_max, adc_bits, trig_values, pwm_frequency_hz,
                                   max_order, paper * scale, current_loop_bandwidth_hz,
                                   current_loop_delay_s, transducer_bandwidth_hz)
    return Prediction(
        source="word_length", pk_pk_pu=paper * scale, base=MEAN_TORQUE_BASE,
        base_nm=op.mean_torque_nm, order=None,
        inputs={"word_length_bits": bits, "full_scale_current_a": i_max, **op.to_dict()},
        equations="eqs 10-14, T_r = 10/2^(n-1)", assumptions=[
            "worst-case bound: every truncation error at its maximum with aligned signs",
            "per-unit storage with full scale I_max, no other scaling",
            "ideal current regulation turns the I_q error into an actual current error",
            "no ADC or PWM quantization (those are separate sources)"],
        extras={"paper_pk_pk_pu": paper,
                "paper_base": f"torque at the full-scale current I_max = {i_max:g} A",
                "iq_error_bound_pu": iq_error_bound_pu(bits),
                "balanced_bound_pk_pk_pu": balanced_pk_pk_pu(bits, op.current_a / i_max) * scale})


def _derived_prediction(op: OperatingPoint, bits: int, i_max: float, adc_bits: int,
                        trig_values: str, pwm_frequency_hz: float, max_order: int,
                        paper_pu: float, current_loop_bandwidth_hz: float | None = None,
                        current_loop_delay_s: float = 0.0,
                        transducer_bandwidth_hz: float | None = None) -> Prediction:
    adc = check_range("adc_bits", adc_bits, 6, 24, unit=" bits")
    if adc != int(adc):
        raise InputError(f"adc_bits={adc_bits!r} is not an integer (allowed 6..24 bits)")
    if trig_values not in TRIG_VALUES:
        raise InputError(f"trig_values={trig_values!r} is not one of {', '.join(TRIG_VALUES)}")
    f_sw = check_range("pwm_frequency_hz", pwm_frequency_hz, 2000.0, 50000.0, unit=" Hz")
    orders = check_range("max_order", max_order, 1, 10000)
    if current_loop_bandwidth_hz is not None:
        check_range("current_loop_bandwidth_hz", current_loop_bandwidth_hz, 0.0, 0.5 * f_sw,
                    unit=" Hz", low_open=True)
    delay = check_range("current_loop_delay_s", current_loop_delay_s, 0.0, 0.01, unit=" s")
    if transducer_bandwidth_hz is not None:
        check_range("transducer_bandwidth_hz", transducer_bandwidth_hz, 0.0, 1e6, unit=" Hz",
                    low_open=True)
    terms = derived_terms_pu(op, bits, adc_bits=int(adc), full_scale_current_a=i_max,
                             trig_values=trig_values, pwm_frequency_hz=f_sw,
                             max_order=int(orders),
                             current_loop_bandwidth_hz=current_loop_bandwidth_hz,
                             current_loop_delay_s=delay,
                             transducer_bandwidth_hz=transducer_bandwidth_hz)
    return Prediction(
        source="word_length", pk_pk_pu=terms["pk_pk_pu"], base=MEAN_TORQUE_BASE,
        base_nm=op.mean_torque_nm, order=1.0 if terms["order1_dominant"] else None,
        inputs={"word_length_bits": bits, "full_scale_current_a": i_max, "model": "derived",
                "adc_bits": int(adc), "trig_values": trig_values, "pwm_frequency_hz": f_sw,
                "max_order": int(orders), "current_loop_bandwidth_hz": current_loop_bandwidth_hz,
                "current_loop_delay_s": delay, "transducer_bandwidth_hz": transducer_bandwidth_hz,
                **op.to_dict()},
        equations="truncation bias of eqs 10-14 (not in the paper; the paper's bound is "
                  "10/2^(n-1))",
        assumptions=[
            "two's-complement truncation toward -inf; truncated values spread over many LSBs",
            f"ADC of {int(adc)} bits over ±I_max, read into the word (ADC and Q full scale equal)",
            f"trigonometric values: {trig_values}",
            ("the computed I_q error reaches the current through the stated loop "
             f"({current_loop_bandwidth_hz:g} Hz, {delay:g} s) and the torque reading through "
             f"the stated transducer ({transducer_bandwidth_hz or 0:g} Hz; 0: ideal)")
            if current_loop_bandwidth_hz else
            "ideal regulation of the computed I_q; the loop follows the order-1 error",
            "broadband part: truncation noise sampled at the PWM rate, orders "
            f"1..{int(orders)}, half of it taken as synchronous (between none and all)",
            "mean-torque shift of the truncated reference and integrator not modelled"],
        expected_range_pu=(terms["low_pu"], terms["high_pu"]),
        extras={"paper_pk_pk_pu": paper_pu, "order1_pk_pk_pu": terms["order1_pk_pk_pu"],
                "broadband_pk_pk_pu": terms["broadband_pk_pk_pu"],
                "sensor_bias_a": terms["sensor_bias_a"],
                "truncation_noise_std_a": terms["truncation_noise_std_a"]})
