"""Inverter dead time (paper III-D, eqs 32-38): order-6 ripple, magnitude and phase.

The paper's eq 38 is a per-event current step (Δi_q = (2/3)·V_dc·T_d/L_s) read as a pk-pk
ripple; it ignores the current loop that rejects the disturbance. The plan judges against the
current-clamping model of hil.model.dead_time: the average leg error T_d·f_sw·V_dc of eqs 32-37
with the sign of the actual current (the current dwells at zero at each crossing), the drive's
current loop (design, bandwidth, delay and angle compensation from the bench file:
``hil.current_loop``) and the stated transducer response. The
paper's figure is recorded beside it (prediction.extras).

Validity region (``hil.validity``, checked by the pre-flight before the bench is touched): every
edge of every leg keeps its dead time within the PWM period, i.e. the inverter's voltage (the
steady phasor at the signed speed plus the dead time's loss along the current) within
(V_dc/√3)·(1 − 4·T_d·f_sw) (``hil.model.voltage.linear_limit_v``, the one limit); the plant
corner order R/(L·|ω_e|) at most the calibration set's (``hil.validity.DEAD_TIME_MAX_PLANT_CORNER_ORDER``: beyond it the
loop spreads the ripple over every analysed order and its pk-pk is not resolved from the drive's
own, issue 30); and the bench's resolvable floor at most half of the pk-pk acceptance
half-width. Captured at ≥ 4 × the stated transducer bandwidth
(``conditions.transducer_limited_rate``).

Verdicts per point: the pk-pk against the model (±35 % + the bench floor 0.001 pu), the order-6
amplitude against the model's (±15 %, guarded by its U; ``order6_amplitude_check``) and the
order-6 phase (±5° + the turn the bench floor can give it, ``phase_tolerance_rad``). Tolerances set on a calibration set (Table I, forward, seed 1) and checked
on a disjoint holdout set (``studies/dead_time_calibration.py``, hil/model/README.md).
"""

import math

import pytest

from hil.analysis.decision import DecisionRule, decide_phase
from hil.outcome_kinds import not_determinable
from ripple_hil_testplans import conditions as c
from ripple_hil_testplans.sensitivity import check_sensitivity

pytestmark = pytest.mark.ripple_source("dead_time")

#: pk-pk rule: ±35 % (set when the model lacked the PWM ripple at the crossings: the calibration
#: set then needed 0.345); with the ripple the calibration set needs 0.10 and the holdout 0.28
#: (hil/model/README.md), so it is kept as the coarse check whose half-width the region's floor
#: refusal is measured against; abs_tol the bench floor (DERIVED_ESTIMATE_RULE's 0.001 pu).
DEAD_TIME_RULE = DecisionRule(rel_tol=0.35, abs_tol_pu=0.001)
#: order-6 amplitude band: the calibration set's largest (|A_m − A_p| + U)/A_p is 0.098
#: (Table I 1000 rpm / 5 A); + 0.05 margin → ±15 %. The holdout needs 0.143 (motor C, 1300 rpm /
#: 5 A), inside; 0.10 was tried first and failed that point (hil/model/README.md).
ORDER6_AMPLITUDE_TOL = 0.15
#: order-6 phase tolerance, rad: the calibration set's largest |Δφ| + U (4.3°) → 5°.
PHASE_TOLERANCE_RAD = math.radians(5.0)


def prediction_params(config) -> dict:
    return {"model": "current_clamping", **c.stated_current_loop(config),
            "transducer_bandwidth_hz": config.torque.bandwidth_hz}


def order6_amplitude_check(result, prediction, tolerance: float = ORDER6_AMPLITUDE_TOL) -> dict | None:
    """The order-6 amplitude measured against the model's (both N·m, the model's includes the
    stated loop and transducer), guarded: |A_m − A_p| ≤ tolerance·A_p − U(A_6), U = 2·u(A_6) from
    the analysis. A ``hil.selfcheck``-form dict (``passed``); None when U(A_6) is not below
    tolerance·A_p (the order is too small here for this check; the pk-pk verdict stands).

    Why beside the pk-pk: the pk-pk of a small ripple carries the bench's floor (the twin's own
    0.1 % pk-pk on a 2-pole 24 V motor), which the pk-pk band must allow for; order 6 alone is
    resolved to ≈ 1 % of itself and the model holds it within 0.87-1.05× (README), so its band
    can be tight enough to fail a drive that applies 70 % of the commanded dead time."""
    predicted_nm = prediction.extras["order6_amplitude_pu"] * abs(prediction.base_nm)
    measured_nm = float(result.amplitude_nm[5])
    expanded_nm = 2.0 * float(result.amplitude_u_nm[5])
    allowance_nm = tolerance * predicted_nm - expanded_nm
    if allowance_nm <= 0.0:
        return None
    passed = bool(math.isfinite(measured_nm) and abs(measured_nm - predicted_nm) <= allowance_nm)
    return {"name": "dead-time order-6 amplitude vs model", "measured": measured_nm,
            "expected": predicted_nm, "unit": "N*m", "tolerance": allowance_nm,
            "passed": passed,
            "detail": (f"order-6 amplitude {measured_nm:.4g} N·m ± {expanded_nm:.2g} (k=2) vs the "
                       f"current-clamping model's {predicted_nm:.4g} N·m: ratio "
                       f"{measured_nm / predicted_nm:.3f}, band ±{tolerance:.0%} less U "
                       "(guarded)")}


def phase_tolerance_rad(prediction, floor_pk_pk_nm: float) -> float:
    """The order-6 phase zone, rad: the calibrated ±5° plus asin(A_floor/A_6), the turn that an
    order-6 content of the bench's own, up to half its resolvable pk-pk floor (N·m), can give the
    measured phasor of predicted amplitude A_6 — the phase's counterpart of the pk-pk rule's
    floor allowance (``abs_tol_pu``). Without it the correct drive failed at 8 poles, −2475 rpm
    / 20 A, 2 µs: order 6 at 990 Hz, amplitude right (1.004×) but +6.8° ± 2.0° against ±5°,
    with A_6 = 0.0036 N·m against a 0.0005 N·m floor amplitude (asin: 8.0°)."""
    amplitude_nm = prediction.extras["order6_amplitude_pu"] * abs(prediction.base_nm)
    if amplitude_nm <= 0.0:
        return math.pi / 2
    return PHASE_TOLERANCE_RAD + math.asin(min(1.0, 0.5 * floor_pk_pk_nm / amplitude_nm))


def phase_judge(result, prediction, plan, bench):
    """The order-6 phase verdict (``PointPlan.phase``, recorded as ``verdict.phase``): the
    model's phase (it already includes the stated loop and transducer) against
    :func:`phase_tolerance_rad` (±5° + the bench floor's turn), guarded by the measured phase's
    U = 2·u(A_6)/A_6. None — no phase verdict, the point is then not determinable — when that U
    is not below the tolerance (the order is too small to have a phase here), or when the bench
    file states no ``[torque] bandwidth_hz`` (the transducer's phase lag is then unknown, as for
    ``ripple_hil_testplans.phase``; the model's phase would assume an ideal transducer and reject
    a correct drive: +0.161 rad against ±0.087 at −700 rpm / 12 A). ``bench`` None (a study):
    no floor term."""
    from hil.validity import bench_floor_nm

    if bench is not None and bench.config.torque.bandwidth_hz is None:
        return None
    floor_nm = (bench_floor_nm(bench.config)
                if bench is not None and hasattr(bench.config, "uncertainty_inputs") else 0.0)
    tolerance = phase_tolerance_rad(prediction, floor_nm)
    verdict = decide_phase(result, 6, prediction.extras["order6_phase_rad"],
                           tolerance_rad=min(tolerance, 0.99 * math.pi))
    return verdict if verdict.guard_band_rad < tolerance else None


def plan(config, injection):
    """The point, captured at least at ``conditions.MIN_RATE_PER_TRANSDUCER_BANDWIDTH`` × the
    stated transducer bandwidth (``conditions.transducer_limited_rate``: at 2 kHz the 2-pole
    24 V motor at 250 rpm read 1.2-1.8× this model's pk-pk from folded drive content)."""
    return c.transducer_limited_rate(c.point(
        config.operating_point, "dead_time", injection, DEAD_TIME_RULE, named_order=6,
        prediction_params=prediction_params(config), phase=phase_judge,
        expectation="judged against the current-clamping model (average leg error with the "
                    "actual current's sign, the stated loop and transducer); the order-6 phase "
                    "is judged too; the paper's eq 38 per-event step is recorded for comparison "
                    "only"), config)


@pytest.mark.parametrize("injection", c.DEAD_TIME_SWEEP, ids=c.sweep_id)
def test_dead_time(measure, bench, record, injection):
    outcome = measure(plan(bench.config, injection))
    amplitude = order6_amplitude_check(outcome.result, outcome.prediction)
    note = ("order-6 amplitude not judged: its U is not below the ±"
            f"{ORDER6_AMPLITUDE_TOL:.0%} band here" if amplitude is None else
            f"{amplitude['detail']}: {'pass' if amplitude['passed'] else 'FAIL'}")
    record.update_test(outcome.test_id, notes=[*outcome.entry.get("notes", []), note])
    assert outcome.passed, outcome.summary()
    assert amplitude is None or amplitude["passed"], f"{outcome.test_id}: {note}"
    if outcome.phase_verdict is None:
        pytest.skip(not_determinable(
            "order-6 phase: the bench file states no [torque] bandwidth_hz, so the transducer's "
            "phase lag is unknown" if bench.config.torque.bandwidth_hz is None else
            "order-6 phase: its U (2·u(A_6)/A_6) is not below the "
            f"±{math.degrees(PHASE_TOLERANCE_RAD):.0f}° tolerance"))


def test_dead_time_sensitivity(record):
    """The sweep's measured ripple scales with the injection as the model says (slope 1)."""
    result = check_sensitivity(record, "dead_time", DEAD_TIME_RULE.rel_tol)
    assert result["accepted"], result["statement"]
