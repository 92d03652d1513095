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
"""

from __future__ import annotations

import math

from hil.errors import InputError
from hil.model.core import MEAN_TORQUE_BASE, OperatingPoint, Prediction, check_range

#: Q-format full scale of the current: the ADC range of the contract, ±100 A.
FULL_SCALE_CURRENT_A = 100.0
WORD_LENGTH_RANGE_BITS = (6, 32)


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


def predict_word_length(op: OperatingPoint, *, word_length_bits: int,
                        full_scale_current_a: float = FULL_SCALE_CURRENT_A) -> Prediction:
    """Worst-case broadband ripple bound of an n-bit controller, per unit of the mean torque."""
    bits = check_bits(word_length_bits)
    i_max = check_range("full_scale_current_a", full_scale_current_a, 0.0, 1e4, unit=" A",
                        low_open=True)
    paper = paper_pk_pk_pu(bits)
    scale = i_max / (op.current_a * math.cos(op.current_angle_rad))
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
