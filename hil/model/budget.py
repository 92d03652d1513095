"""Ripple budget: combine sources at one operating point, and invert a ripple specification.

Combination: every prediction is converted to N·m and divided by the mean torque of the
operating point, (3/2)·E·I·cos φ/ω_m, so sources with different per-unit bases add up. Two rules:
``worst_case_sum_pu`` (pk-pk add; peaks aligned — an upper bound) and ``rss_pu`` (root-sum-square;
independent, uncorrelated sources at different orders — a typical value, not a bound).

Inversion (the paper's conclusion asks for it): for a limit on pk-pk ripple, the coarsest encoder,
the shortest word length, the largest sensor offset and gain mismatch (worst case over the
sensors' signs, eqs 20 and 26), the coarsest PWM counter, the lowest PWM frequency and the
longest dead time that meet it. ``allocation`` says how the limit is shared among the seven
sources: "alone" (each source may use all of it), "equal_sum" (limit/N each, so the worst-case
sum meets the limit) or "equal_rss" (limit/√N each).

``forms`` chooses the model of each share (``FORMS`` says which, the budget reports it):
"derived" (default) uses the physically derived forms where the paper's do not describe a
closed-loop drive — word length: the truncation-bias model (the paper's 10/2^(n−1) is a bound
3–4× above it); PWM resolution: the closed-loop bound (eq 28 is open loop, ~4× above it); PWM
switching: the switched-torque form (eqs 29–31 are 10–12 % low); dead time: the average-voltage
model through the current loop (eq 38 is ~4× too high for a closed loop). The loop is the one
given, else the simulated drive's (bandwidth 0.08·f_pwm, delay 1.5 PWM periods), and the budget
says so. "paper" uses the paper's own forms throughout.
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
from hil.model.pwm_switching import PWM_FREQUENCY_RANGE_HZ
from hil.model.sources import predict
from hil.model.word_length import WORD_LENGTH_RANGE_BITS

ALLOCATIONS = ("alone", "equal_sum", "equal_rss")
#: The sources a designer chooses, in the order the budget reports them.
DESIGN_SOURCES = ("encoder", "word_length", "dc_offset", "gain_mismatch", "pwm_resolution",
                  "pwm_switching", "dead_time")
#: The model of each share, per choice of ``forms`` (reported with the budget).
FORMS: dict[str, dict[str, str]] = {
    "derived": {
        "encoder": "eq 9 (exact under ideal regulation)",
        "word_length": "derived truncation-bias model (the paper's 10/2^(n-1) bound is 3-4x "
                       "above it)",
        "dc_offset": "eq 20, worst case (both sensors offset alike)",
        "gain_mismatch": "eq 26, worst case (opposite gain errors)",
        "pwm_resolution": "closed-loop bound (derived; eq 28 is open loop)",
        "pwm_switching": "switched-torque form, SVPWM (derived; eqs 29-31 are 10-12 % low); "
                         "air-gap ripple at the switching frequency, above a transducer's band",
        "dead_time": "average-voltage model through the current loop (derived; the paper's "
                     "eq 38 is ~4x too high for a closed loop)"},
    "paper": {
        "encoder": "eq 9", "word_length": "eq 14 bound 10/2^(n-1)", "dc_offset": "eq 20",
        "gain_mismatch": "eq 26", "pwm_resolution": "eq 28 (open loop), dc-bus step",
        "pwm_switching": "eqs 29-31 (2·Δi/I)", "dead_time": "eq 38 (Δi_q/I_nom)"},
}
#: The simulated drive's current loop, assumed when none is given (hil.sim FirmwareModel).
DEFAULT_LOOP_BANDWIDTH_PER_PWM = 0.08
DEFAULT_LOOP_DELAY_PERIODS = 1.5


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
    forms: str = "derived"
    models: dict[str, str] = field(default_factory=dict)
    loop: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {"limit_pu": self.limit_pu, "limit_pct": 100 * self.limit_pu,
                "allocation": self.allocation, "share_pu": self.share_pu,
                "forms": self.forms, "models": dict(self.models), "loop": dict(self.loop),
                "limits": self.limits, "check": self.check.to_dict() if self.check else None}


def _rebased(op: OperatingPoint, source: str, **params: Any) -> float:
    return predict(source, op, **params).pk_pk_nm / op.mean_torque_nm


def _largest(func, low: float, high: float, share: float) -> tuple[float, bool]:
    """Largest x in (low, high] with func(x) ≤ share for an increasing func; (x, capped)."""
    if func(high) <= share:
        return high, True
    return brentq(lambda x: func(x) - share, low, high, xtol=1e-12 * high, rtol=1e-10), False


def current_loop(pwm_frequency_hz: float, bandwidth_hz: float | None,
                 delay_s: float | None) -> dict[str, Any]:
    """The loop the derived forms use: the one given, else the simulated drive's (stated)."""
    assumed = [name for name, value in (("bandwidth", bandwidth_hz), ("delay", delay_s))
               if value is None]
    return {"current_loop_bandwidth_hz": bandwidth_hz if bandwidth_hz is not None
            else DEFAULT_LOOP_BANDWIDTH_PER_PWM * pwm_frequency_hz,
            "current_loop_delay_s": delay_s if delay_s is not None
            else DEFAULT_LOOP_DELAY_PERIODS / pwm_frequency_hz,
            "assumed": ("the simulated drive's " + " and ".join(assumed) +
                        " (0.08·f_pwm, 1.5 PWM periods)") if assumed else None}


def invert(op: OperatingPoint, limit_pu: float, *, allocation: str = "equal_sum",
           forms: str = "derived", nominal_current_a: float | None = None,
           pwm_frequency_hz: float = 20000.0,
           current_loop_bandwidth_hz: float | None = None,
           current_loop_delay_s: float | None = None) -> Specification:
    """Invert a pk-pk limit (per unit of the mean torque) into per-source parameter limits."""
    limit = check_range("limit_pu", limit_pu, 0.0, 1.0, unit=" per unit", low_open=True)
    if allocation not in ALLOCATIONS:
        raise InputError(f"allocation={allocation!r} is not one of {', '.join(ALLOCATIONS)}")
    if forms not in FORMS:
        raise InputError(f"forms={forms!r} is not one of {', '.join(FORMS)}")
    f_pwm = check_range("pwm_frequency_hz", pwm_frequency_hz, 2000.0, 50000.0, unit=" Hz")
    loop = current_loop(f_pwm, current_loop_bandwidth_hz, current_loop_delay_s)
    loop_params = {"current_loop_bandwidth_hz": loop["current_loop_bandwidth_hz"]}
    derived = forms == "derived"
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

    word_params = {"model": "derived", "pwm_frequency_hz": f_pwm} if derived else {}
    bits = next((n for n in range(WORD_LENGTH_RANGE_BITS[0], WORD_LENGTH_RANGE_BITS[1] + 1)
                 if _rebased(op, "word_length", word_length_bits=n, **word_params) <= share), None)
    limits["word_length"] = {"word_length_bits": bits, "met": bits is not None, **word_params}
    design["word_length"] = {"word_length_bits": bits or WORD_LENGTH_RANGE_BITS[1],
                             **word_params}  # the longest word checked when none meets it

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

    pwm_params = {"model": "closed_loop", **loop_params} if derived else {}
    counts_pwm = _smallest_pwm_counts(op, share, pwm_params)
    limits["pwm_resolution"] = {"pwm_period_counts_min": counts_pwm, "met": counts_pwm is not None,
                                "voltage_step_basis": "dc_bus", **pwm_params}
    design["pwm_resolution"] = {"pwm_period_counts": counts_pwm or 65535, **pwm_params}

    switching_params = {"model": "switched_torque" if derived else "paper"}
    f_low, met = _lowest_pwm_frequency(op, share, switching_params)
    limits["pwm_switching"] = {"pwm_frequency_hz_min": f_low, "met": met, **switching_params}
    design["pwm_switching"] = {"pwm_frequency_hz": f_low, **switching_params}  # 50 kHz if unmet

    dt_params = ({"model": "average_voltage", "pwm_frequency_hz": f_pwm, **loop_params,
                  "current_loop_delay_s": loop["current_loop_delay_s"]} if derived else
                 {"model": "paper", "nominal_current_a": nominal_current_a,
                  "pwm_frequency_hz": f_pwm})
    dead, capped = _largest(lambda t: _rebased(op, "dead_time", dead_time_s=t, **dt_params),
                            1e-15, DEAD_TIME_RANGE_S[1], share)
    limits["dead_time"] = {"dead_time_s": dead, "dead_time_us": dead * 1e6,
                           "capped_at_range": capped, **dt_params}
    design["dead_time"] = {"dead_time_s": dead, **dt_params}
    return Specification(limit, allocation, share, limits, combine_sources(op, design), forms,
                         dict(FORMS[forms]), loop if derived else {})


def _lowest_pwm_frequency(op: OperatingPoint, share: float,
                          params: dict[str, Any]) -> tuple[float, bool]:
    """Lowest PWM frequency whose switching ripple meets the share (it falls as 1/f)."""
    def ripple(frequency_hz: float) -> float:
        return _rebased(op, "pwm_switching", pwm_frequency_hz=frequency_hz, **params)
    low, high = PWM_FREQUENCY_RANGE_HZ
    if ripple(high) > share:
        return high, False
    if ripple(low) <= share:
        return low, True
    return brentq(lambda f: ripple(f) - share, low, high, xtol=1e-6), True


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


def _smallest_pwm_counts(op: OperatingPoint, share: float,
                         params: dict[str, Any]) -> int | None:
    low, high = 8, 65535
    if _rebased(op, "pwm_resolution", pwm_period_counts=high, **params) > share:
        return None
    while low < high:  # pk-pk falls as 1/C: bisection on the integer counter top
        middle = (low + high) // 2
        if _rebased(op, "pwm_resolution", pwm_period_counts=middle, **params) <= share:
            high = middle
        else:
            low = middle + 1
    return low
