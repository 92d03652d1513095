"""Ripple budget: combine sources at one operating point, and invert a ripple specification.

Combination: every prediction is converted to N·m and divided by the mean torque of the
operating point, (3/2)·E·I·cos φ/ω_m, so sources with different per-unit bases add up. Two rules:
``worst_case_sum_pu`` (pk-pk add; peaks aligned — an upper bound) and ``rss_pu`` (root-sum-square;
independent, uncorrelated sources at different orders — a typical value, not a bound).

Inversion (the paper's conclusion asks for it): for a limit on pk-pk ripple, the coarsest encoder,
the shortest word length, the largest sensor offset and gain mismatch (worst case over the
sensors' signs, eqs 20 and 26), the coarsest PWM counter and the longest dead time that meet it.
``allocation`` says how the limit is shared: "alone" (each source may use all of it),
"equal_sum" (limit/N each, so the worst-case sum meets the limit) or "equal_rss" (limit/√N each).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from scipy.optimize import brentq

from hil.errors import InputError
from hil.model import dc_offset, gain_mismatch
from hil.model.core import OperatingPoint, Prediction, check_range
from hil.model.dead_time import DEAD_TIME_RANGE_S
from hil.model.encoder import DRIVE_COUNTS_PER_REV
from hil.model.sources import predict
from hil.model.word_length import WORD_LENGTH_RANGE_BITS

ALLOCATIONS = ("alone", "equal_sum", "equal_rss")
#: The sources a designer chooses, in the order the budget reports them.
DESIGN_SOURCES = ("encoder", "word_length", "dc_offset", "gain_mismatch", "pwm_resolution",
                  "dead_time")


@dataclass(frozen=True)
class Combination:
    """Several sources at one operating point, per unit of its mean torque."""

    contributions_pu: dict[str, float]
    worst_case_sum_pu: float
    rss_pu: float
    base_nm: float

    def to_dict(self) -> dict[str, Any]:
        return {"contributions_pu": dict(self.contributions_pu),
                "worst_case_sum_pu": self.worst_case_sum_pu, "rss_pu": self.rss_pu,
                "base": "mean torque (3/2)·E·I·cos φ/ω_m at the operating point",
                "base_nm": self.base_nm,
                "rules": {"worst_case_sum_pu": "pk-pk values added (peaks aligned): upper bound",
                          "rss_pu": "root-sum-square (independent sources): typical value"}}


def combine(op: OperatingPoint, predictions: list[Prediction]) -> Combination:
    """Worst-case sum and RSS of the predictions' pk-pk, re-based to the operating mean torque."""
    contributions = {p.source: p.pk_pk_nm / op.mean_torque_nm for p in predictions}
    values = list(contributions.values())
    return Combination(contributions, sum(values), math.sqrt(sum(v * v for v in values)),
                       op.mean_torque_nm)


def combine_sources(op: OperatingPoint, params_by_source: dict[str, dict[str, Any]]) -> Combination:
    """``combine`` for {source: params} — one prediction per source."""
    return combine(op, [predict(source, op, **params)
                        for source, params in params_by_source.items()])


@dataclass(frozen=True)
class Specification:
    """The loosest controller parameters that keep each source within its share of a limit."""

    limit_pu: float
    allocation: str
    share_pu: float
    limits: dict[str, dict[str, Any]] = field(default_factory=dict)
    check: Combination | None = None

    def to_dict(self) -> dict[str, Any]:
        return {"limit_pu": self.limit_pu, "limit_pct": 100 * self.limit_pu,
                "allocation": self.allocation, "share_pu": self.share_pu,
                "limits": self.limits, "check": self.check.to_dict() if self.check else None}


def _rebased(op: OperatingPoint, source: str, **params: Any) -> float:
    return predict(source, op, **params).pk_pk_nm / op.mean_torque_nm


def _largest(func, low: float, high: float, share: float) -> tuple[float, bool]:
    """Largest x in (low, high] with func(x) ≤ share for an increasing func; (x, capped)."""
    if func(high) <= share:
        return high, True
    return brentq(lambda x: func(x) - share, low, high, xtol=1e-12 * high, rtol=1e-10), False


def invert(op: OperatingPoint, limit_pu: float, *, allocation: str = "equal_sum",
           dead_time_model: str = "paper", nominal_current_a: float | None = None,
           pwm_frequency_hz: float = 20000.0,
           current_loop_bandwidth_hz: float | None = None,
           current_loop_delay_s: float = 0.0) -> Specification:
    """Invert a pk-pk limit (per unit of the mean torque) into per-source parameter limits."""
    limit = check_range("limit_pu", limit_pu, 0.0, 1.0, unit=" per unit", low_open=True)
    if allocation not in ALLOCATIONS:
        raise InputError(f"allocation={allocation!r} is not one of {', '.join(ALLOCATIONS)}")
    count = len(DESIGN_SOURCES)
    share = {"alone": limit, "equal_sum": limit / count,
             "equal_rss": limit / math.sqrt(count)}[allocation]
    limits: dict[str, dict[str, Any]] = {}
    design: dict[str, dict[str, Any]] = {}

    res, capped = _largest(lambda r: _rebased(op, "encoder", resolution_elec_rad=r), 1e-9,
                           math.pi / 3, share)
    decimation = math.floor(res / (2 * math.pi * op.motor.pole_pairs / DRIVE_COUNTS_PER_REV) + 1e-9)
    counts = math.ceil(2 * math.pi * op.motor.pole_pairs / res - 1e-9)
    limits["encoder"] = {"resolution_elec_rad": res, "resolution_elec_deg": math.degrees(res),
                         "encoder_decimation": decimation, "encoder_counts_per_rev_min": counts,
                         "capped_at_hall_60deg": capped}
    design["encoder"] = {"resolution_elec_rad": res}

    bits = next((n for n in range(WORD_LENGTH_RANGE_BITS[0], WORD_LENGTH_RANGE_BITS[1] + 1)
                 if _rebased(op, "word_length", word_length_bits=n) <= share), None)
    limits["word_length"] = {"word_length_bits": bits, "met": bits is not None}
    if bits is not None:
        design["word_length"] = {"word_length_bits": bits}

    per_unit_offset = share / dc_offset.worst_case_pk_pk_pu(1.0, op.current_angle_rad)
    offset_a = min(per_unit_offset * op.current_a, dc_offset.OFFSET_RANGE_A)
    limits["dc_offset"] = {"offset_pu": offset_a / op.current_a, "offset_a": offset_a,
                           "rule": "worst case, both sensors offset alike (eq 20)"}
    design["dc_offset"] = {"ia_offset_a": offset_a, "ib_offset_a": offset_a}

    gain, capped = _largest(lambda g: gain_mismatch.worst_case_pk_pk_pu(g, op.current_angle_rad)
                            * _gain_rebase(op, g), 1e-12, gain_mismatch.GAIN_ERROR_RANGE_PU, share)
    limits["gain_mismatch"] = {"gain_error_pu": gain, "rule": "worst case g_a = −g_b (eq 26)",
                               "capped_at_range": capped}
    design["gain_mismatch"] = _worst_gain_params(op, gain)

    counts_pwm = _smallest_pwm_counts(op, share)
    limits["pwm_resolution"] = {"pwm_period_counts_min": counts_pwm, "met": counts_pwm is not None,
                                "voltage_step_basis": "dc_bus"}
    if counts_pwm is not None:
        design["pwm_resolution"] = {"pwm_period_counts": counts_pwm}

    dt_params = {"model": dead_time_model, "nominal_current_a": nominal_current_a,
                 "pwm_frequency_hz": pwm_frequency_hz,
                 "current_loop_bandwidth_hz": current_loop_bandwidth_hz,
                 "current_loop_delay_s": current_loop_delay_s}
    dead, capped = _largest(lambda t: _rebased(op, "dead_time", dead_time_s=t, **dt_params),
                            1e-15, DEAD_TIME_RANGE_S[1], share)
    limits["dead_time"] = {"dead_time_s": dead, "dead_time_us": dead * 1e6,
                           "capped_at_range": capped, **dt_params}
    design["dead_time"] = {"dead_time_s": dead, **dt_params}
    return Specification(limit, allocation, share, limits, combine_sources(op, design))


def _gain_rebase(op: OperatingPoint, gain: float) -> float:
    """Worst-case gain pk-pk is per unit of its own (shifted) mean; factor to the op's mean."""
    params = _worst_gain_params(op, gain)
    prediction = predict("gain_mismatch", op, **params)
    return prediction.base_nm / op.mean_torque_nm


def _worst_gain_params(op: OperatingPoint, gain: float) -> dict[str, float]:
    first = gain_mismatch.pk_pk_pu(gain, -gain, op.current_angle_rad)
    second = gain_mismatch.pk_pk_pu(-gain, gain, op.current_angle_rad)
    sign = 1.0 if first >= second else -1.0
    return {"ia_gain_error_pu": sign * gain, "ib_gain_error_pu": -sign * gain}


def _smallest_pwm_counts(op: OperatingPoint, share: float) -> int | None:
    low, high = 8, 65535
    if _rebased(op, "pwm_resolution", pwm_period_counts=high) > share:
        return None
    while low < high:  # pk-pk falls as 1/C: bisection on the integer counter top
        middle = (low + high) // 2
        if _rebased(op, "pwm_resolution", pwm_period_counts=middle) <= share:
            high = middle
        else:
            low = middle + 1
    return low
