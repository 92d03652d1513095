"""Measured vs predicted ripple: magnitude with a guard band (ILAC-G8) and order signature.

Magnitude: the tolerance zone around the prediction ``p_pred`` is
``[p_pred − T, p_pred + T]`` with ``T = abs_tol_pu + rel_tol·|p_pred|``. The guard band is
``w = guard_band_factor·U`` (U: expanded uncertainty of the measured pk_pk_pu, k = 2). With the
measured value x (ILAC-G8:2009, four outcomes):

* **pass** — ``x ± w`` lies inside the zone (acceptance limits ``p_pred ± (T − w)``);
* **conditional pass** — x inside the zone, but ``x ± w`` crosses a limit;
* **conditional fail** — x outside the zone, but ``x ± w`` reaches into it;
* **fail** — ``x ± w`` lies wholly outside the zone.

Signature: the predicted order must be the dominant order of the measured spectrum, or, when
``min_order_share`` is set, at least carry that share of the AC power. A wrong signature makes the
decision "fail" whatever the magnitude (the measured ripple is not the predicted source's).
``guarded_pass`` — the binary rule for CI gating — is True only for "pass".

Quantity (``quantity``): ``"pk_pk"`` (default) judges ``pk_pk_pu``; ``"named_order_pk_pk"``
judges the pk-pk 2·A_N/|mean| of the predicted order N alone (its sinusoid), against the
prediction's ``extras["order_pk_pk_pu"]``, with the U of that amplitude
(:func:`named_order_value`). It is for a source whose ripple sits at one order and its
harmonics while the drive's own floor is spread over all orders (the encoder staircase at
standstill, where the current ADC's fixed quantisation pattern lifts the pk-pk but not A_N).

Upper bound (``upper_bound=True``): where the closed form is a worst-case bound (word length,
eq 14) or a ceiling (the baseline), the zone is one-sided, ``[0, p_pred + T]``: pass when
``x + w`` is at or below the limit, conditional pass when only ``x`` is, and so on.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace

from hil.analysis.metrics import RippleResult
from hil.errors import InputError

DECISIONS = ("pass", "conditional pass", "conditional fail", "fail")
#: What a rule judges (module docstring): the pk-pk, or the predicted order's own pk-pk 2·A_N.
QUANTITIES = ("pk_pk", "named_order_pk_pk")


@dataclass(frozen=True)
class DecisionRule:
    """The acceptance rule of a test, recorded beside its verdict (module docstring)."""

    rel_tol: float = 0.25
    abs_tol_pu: float = 0.005
    guard_band_factor: float = 1.0
    check_signature: bool = True
    min_order_share: float | None = None
    upper_bound: bool = False
    #: Judge against the prediction's own stated range (a derived model's ``expected_range_pu``)
    #: widened by ``abs_tol_pu`` (the bench floor) and ``rel_tol`` of each end, instead of
    #: prediction ± T.
    expected_range: bool = False
    #: One of QUANTITIES (module docstring).
    quantity: str = "pk_pk"

    def __post_init__(self) -> None:
        _require(self.quantity in QUANTITIES, "quantity", self.quantity, ", ".join(QUANTITIES))
        _require(0.0 <= self.rel_tol <= 10.0, "rel_tol", self.rel_tol, "0..10")
        _require(0.0 <= self.abs_tol_pu <= 10.0, "abs_tol_pu", self.abs_tol_pu, "0..10 pu")
        _require(0.0 <= self.guard_band_factor <= 10.0, "guard_band_factor",
                 self.guard_band_factor, "0..10")
        _require(self.rel_tol > 0 or self.abs_tol_pu > 0 or self.upper_bound, "abs_tol_pu",
                 self.abs_tol_pu, "> 0 when rel_tol is 0 (the tolerance zone must not be empty)")
        if self.min_order_share is not None:
            _require(0.0 < self.min_order_share <= 1.0, "min_order_share", self.min_order_share,
                     "0 < share <= 1 or None")

    def tolerance_pu(self, predicted_pu: float) -> float:
        """Half-width T of the tolerance zone around ``predicted_pu``."""
        return self.abs_tol_pu + self.rel_tol * abs(predicted_pu)


def _require(ok: bool, name: str, value, allowed: str) -> None:
    if not ok:
        raise InputError(f"decision rule {name}={value!r} is out of range; allowed: {allowed}")


def classify(measured: float, guard_band: float, lower: float, upper: float) -> str:
    """ILAC-G8 zone of ``measured`` against the limits [lower, upper] with guard band w ≥ 0."""
    if lower + guard_band <= measured <= upper - guard_band:
        return "pass"
    if lower <= measured <= upper:
        return "conditional pass"
    if lower - guard_band <= measured <= upper + guard_band:
        return "conditional fail"
    return "fail"


@dataclass(frozen=True)
class Verdict:
    """Outcome of :func:`decide`, with everything needed to re-check it."""

    decision: str
    guarded_pass: bool
    magnitude_decision: str
    measured_pk_pk_pu: float
    expanded_uncertainty_pu: float
    predicted_pk_pk_pu: float
    lower_limit_pu: float
    upper_limit_pu: float
    guard_band_pu: float
    acceptance_lower_pu: float
    acceptance_upper_pu: float
    predicted_order: int | None
    dominant_order: int
    predicted_order_share: float | None
    signature_ok: bool | None
    reason: str
    rule: DecisionRule

    def to_dict(self) -> dict:
        data = asdict(self)
        data["rule"] = asdict(self.rule)
        data["rule"]["name"] = "ILAC-G8 guard band = guard_band_factor x expanded uncertainty"
        return data


def decide(measured: RippleResult, predicted_pk_pk_pu: float, predicted_order: int | None = None,
           rule: DecisionRule | None = None, *, base_scale: float = 1.0,
           expected_range_pu: tuple[float, float] | None = None) -> Verdict:
    """Compare ``measured.pk_pk_pu`` (with its expanded U) and spectrum with a prediction.

    ``base_scale`` re-expresses the measured pk-pk and its U per unit of another base torque
    (``|measured mean| / base``), e.g. the nameplate mean torque K_t·I·cos φ that the prediction
    is stated in; 1 keeps the measured mean torque as the base. ``expected_range_pu``: the
    prediction's own (low, high) in the same base, needed by a rule with ``expected_range``.
    """
    rule = rule or DecisionRule()
    if not (math.isfinite(base_scale) and base_scale > 0):
        raise InputError(f"base_scale must be a finite number > 0, got {base_scale!r}")
    if not (math.isfinite(predicted_pk_pk_pu) and predicted_pk_pk_pu >= 0):
        raise InputError(f"predicted_pk_pk_pu must be a finite number >= 0, "
                         f"got {predicted_pk_pk_pu!r}")
    if measured.uncertainty is None:
        raise InputError("the measurement was analysed without its uncertainty budget "
                         "(analyze_torque(uncertainty_budget=False)); a verdict needs its U")
    if rule.quantity == "named_order_pk_pk":
        if predicted_order is None:
            raise InputError("a rule judging the named order's pk-pk needs the predicted order")
        value, expanded = (v * base_scale for v in named_order_value(measured, predicted_order))
    else:
        value = measured.pk_pk_pu * base_scale
        expanded = measured.uncertainty.expanded_pu * base_scale
    if not (math.isfinite(value) and math.isfinite(expanded)):
        raise InputError(f"the measurement has no finite pk_pk_pu ({value!r}) or expanded "
                         f"uncertainty ({expanded!r}); a verdict needs >= 2 revolutions and a "
                         "non-zero mean torque")
    tolerance = rule.tolerance_pu(predicted_pk_pk_pu)
    guard = rule.guard_band_factor * expanded
    lower, upper = predicted_pk_pk_pu - tolerance, predicted_pk_pk_pu + tolerance
    if rule.expected_range:
        if expected_range_pu is None:
            raise InputError("this decision rule judges against the prediction's expected range, "
                             "but the prediction states none (use a derived model)")
        low, high = sorted(float(v) for v in expected_range_pu)
        lower = low * (1.0 - rule.rel_tol) - rule.abs_tol_pu
        upper = high * (1.0 + rule.rel_tol) + rule.abs_tol_pu
    if rule.upper_bound:
        lower = 0.0
        magnitude = classify(value, guard, -math.inf, upper)
    else:
        magnitude = classify(value, guard, lower, upper)

    share = signature_ok = None
    if predicted_order is not None:
        if not isinstance(predicted_order, int) or not 1 <= predicted_order <= measured.max_order:
            raise InputError(f"predicted_order must be an integer in 1..{measured.max_order} "
                             f"(the analysed band), got {predicted_order!r}")
        share = measured.order_power_share(predicted_order)
        if rule.check_signature:
            signature_ok = (measured.dominant_order == predicted_order
                            or (rule.min_order_share is not None
                                and share >= rule.min_order_share))
    decision = "fail" if signature_ok is False else magnitude
    what = "pk-pk" if rule.quantity == "pk_pk" else f"order-{predicted_order} pk-pk (2·A)"
    reason = (f"{what} {value:.4g} pu ± {guard:.2g} vs prediction {predicted_pk_pk_pu:.4g} pu, "
              f"tolerance zone [{lower:.4g}, {upper:.4g}]: {magnitude}")
    if signature_ok is False:
        reason += (f"; signature wrong: dominant order {measured.dominant_order}, predicted order "
                   f"{predicted_order} carries {share:.1%} of the AC power")
    return Verdict(decision=decision, guarded_pass=decision == "pass",
                   magnitude_decision=magnitude, measured_pk_pk_pu=value,
                   expanded_uncertainty_pu=expanded, predicted_pk_pk_pu=predicted_pk_pk_pu,
                   lower_limit_pu=lower, upper_limit_pu=upper, guard_band_pu=guard,
                   acceptance_lower_pu=lower if rule.upper_bound else lower + guard,
                   acceptance_upper_pu=upper - guard,
                   predicted_order=predicted_order, dominant_order=measured.dominant_order,
                   predicted_order_share=share, signature_ok=signature_ok, reason=reason,
                   rule=rule)


def named_order_value(measured: RippleResult, order: int) -> tuple[float, float]:
    """(2·A_N/|mean|, its expanded U), per unit of the measured mean torque.

    U (k = the budget's coverage factor): type A from the scatter of the order's coefficient
    between revolutions (``amplitude_u_nm``, doubled for the pk-pk of the sinusoid); the
    transducer's accuracy class as the budget states it for a pk-pk (a span: class % of it) and
    on the mean (sensitivity value/|mean|), rescaled to this value; the DAQ resolution as a
    rectangular ±LSB/2 on each of the M samples the Fourier sum averages, LSB/√12·√(2/M) on A_N
    (the budget's pk-pk row takes two readings, which does not apply to an order's amplitude).
    The pk-pk's residual noise bias does not apply either: A_N of a coherent ripple well above
    the scatter is unbiased to first order.
    """
    budget = measured.uncertainty
    mean_abs = abs(measured.mean_torque_nm)
    value = 2.0 * float(measured.amplitude_nm[order - 1]) / mean_abs
    type_a = 2.0 * float(measured.amplitude_u_nm[order - 1]) / mean_abs
    parts = [type_a]
    scale = value / measured.pk_pk_pu if measured.pk_pk_pu else 0.0
    samples = measured.revolutions * measured.samples_per_rev
    for row in budget.rows:
        if row.source.startswith("type B: transducer accuracy class"):
            parts.append(row.contribution_pu * scale)
        elif row.source.startswith("type B: DAQ resolution"):
            parts.append(2.0 * row.value / math.sqrt(12.0) * math.sqrt(2.0 / samples) / mean_abs)
    expanded = budget.coverage_factor * math.sqrt(sum(p * p for p in parts))
    return value, expanded


# ------------------------------------------------------------------------------ order phase
@dataclass(frozen=True)
class PhaseVerdict:
    """Outcome of :func:`decide_phase` (an order's phase against the model's), rad."""

    decision: str
    guarded_pass: bool
    order: int
    measured_phase_rad: float
    measured_u_rad: float
    predicted_phase_rad: float
    difference_rad: float
    tolerance_rad: float
    guard_band_rad: float
    reason: str

    def to_dict(self) -> dict:
        return asdict(self)


def measured_order_phase(measured: RippleResult, order: int, *,
                         coverage_k: float = 2.0) -> tuple[float, float, float]:
    """(phase per unit of the mean torque, expanded U of the phase, amplitude/U_amplitude) of
    ``order``, rad. The phase is the analysis' φ_k, turned by π when the mean torque is negative
    (the prediction is per unit of the mean); U = k·u(A_k)/A_k, the type-A scatter of the
    phasor across its own direction (small-angle form, valid for A_k ≫ u(A_k))."""
    if not isinstance(order, int) or not 1 <= order <= measured.max_order:
        raise InputError(f"order must be an integer in 1..{measured.max_order}, got {order!r}")
    amplitude = float(measured.amplitude_nm[order - 1])
    u_amplitude = float(measured.amplitude_u_nm[order - 1])
    phase = float(measured.phase_rad[order - 1]) + (math.pi if measured.mean_torque_nm < 0
                                                     else 0.0)
    phase = math.remainder(phase, 2.0 * math.pi)
    resolved = amplitude / (coverage_k * u_amplitude) if u_amplitude > 0 else math.inf
    u_phase = coverage_k * u_amplitude / amplitude if amplitude > 0 else math.inf
    return phase, u_phase, resolved


def decide_phase(measured: RippleResult, order: int, predicted_phase_rad: float, *,
                 tolerance_rad: float, guard_band_factor: float = 1.0,
                 coverage_k: float = 2.0) -> PhaseVerdict:
    """ILAC-G8 on the phase difference d = wrap(φ_measured − φ_predicted) against the zone
    [−T, T] (``tolerance_rad``: the model's phase bounds plus the closed form's own tolerance),
    guard band w = ``guard_band_factor``·U_phase.

    A phase needs its order resolved: an order whose amplitude is not above its own expanded U
    (amplitude ≤ k·u) has no phase and the decision is "fail" with that reason (the model
    predicts a phasor the measurement does not show)."""
    if not (math.isfinite(tolerance_rad) and 0 < tolerance_rad < math.pi):
        raise InputError(f"tolerance_rad must be in (0, pi), got {tolerance_rad!r}")
    phase, u_phase, resolved = measured_order_phase(measured, order, coverage_k=coverage_k)
    difference = math.remainder(phase - predicted_phase_rad, 2.0 * math.pi)
    guard = guard_band_factor * u_phase
    if resolved <= 1.0:
        decision = "fail"
        reason = (f"order {order} not resolved (amplitude {resolved:.2g} x its expanded U): "
                  f"no phase to compare with the predicted {predicted_phase_rad:.3f} rad")
    else:
        decision = classify(difference, guard, -tolerance_rad, tolerance_rad)
        reason = (f"order-{order} phase {phase:.3f} rad ± {guard:.2g} vs predicted "
                  f"{predicted_phase_rad:.3f} rad: difference {difference:+.3f} rad, zone "
                  f"±{tolerance_rad:.3f} rad: {decision}")
    return PhaseVerdict(decision=decision, guarded_pass=decision == "pass", order=order,
                        measured_phase_rad=phase, measured_u_rad=u_phase,
                        predicted_phase_rad=float(predicted_phase_rad),
                        difference_rad=difference, tolerance_rad=float(tolerance_rad),
                        guard_band_rad=guard, reason=reason)


def with_phase(verdict: Verdict, phase: PhaseVerdict | None) -> Verdict:
    """The point's verdict once its order phase is judged too: the decision is the worse of the
    two (as a wrong signature overrides the magnitude), ``magnitude_decision`` keeps the
    magnitude's own, and the reason names the phase. ``phase`` None leaves ``verdict`` as is."""
    if phase is None:
        return verdict
    decision = max(verdict.decision, phase.decision, key=DECISIONS.index)
    return replace(verdict, decision=decision, guarded_pass=decision == "pass",
                   reason=f"{verdict.reason}; phase: {phase.reason}")
