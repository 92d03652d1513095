"""ILAC-G8 verdicts with a guard band equal to U, and the order-signature check."""

from __future__ import annotations

import json

import numpy as np
import pytest

from analysis_synthetic import ripple, speed_profile_angle
from hil.analysis import DECISIONS, DecisionRule, analyze_torque, classify, decide
from hil.errors import InputError


@pytest.fixture(scope="module")
def measured():
    """A noisy order-6 ripple of 4 % pk-pk with a clearly non-zero expanded uncertainty."""
    time_s = np.arange(20_000) / 20_000.0
    angle = speed_profile_angle(time_s, electrical_hz=40.0, variation=0.05)
    torque = ripple(angle, 1.0, {6: (0.02, 0.3), 1: (0.002, 0.0)})
    torque += np.random.default_rng(7).normal(0.0, 0.01, time_s.size)
    res = analyze_torque(time_s, torque, angle, max_order=32, named_order=6)
    assert res.uncertainty.expanded_pu > 0.001
    return res


# tolerance zone half-width T = 3 U; the prediction is placed so that the measured value lies
# on a chosen side of the guard band: |x - pred| = T - 1.5U, T - 0.5U, T + 0.5U, T + 1.5U
@pytest.mark.parametrize("side", [+1, -1])
@pytest.mark.parametrize("distance_u,expected", [
    (1.5, "pass"), (2.5, "conditional pass"), (3.5, "conditional fail"), (4.5, "fail")])
def test_four_verdicts_at_their_side_of_the_guard_band(measured, side, distance_u, expected):
    u = measured.uncertainty.expanded_pu
    rule = DecisionRule(rel_tol=0.0, abs_tol_pu=3 * u)
    predicted = measured.pk_pk_pu + side * distance_u * u
    verdict = decide(measured=measured, predicted_pk_pk_pu=predicted, predicted_order=6, rule=rule)
    assert verdict.decision == expected
    assert verdict.guarded_pass is (expected == "pass")
    assert verdict.signature_ok is True
    assert verdict.guard_band_pu == pytest.approx(u)
    assert verdict.acceptance_upper_pu == pytest.approx(predicted + 2 * u)
    record = json.loads(json.dumps(verdict.to_dict()))
    assert record["rule"]["abs_tol_pu"] == pytest.approx(3 * u)
    assert record["lower_limit_pu"] == pytest.approx(predicted - 3 * u)


def test_relative_and_absolute_tolerance_add(measured):
    rule = DecisionRule(rel_tol=0.1, abs_tol_pu=0.002)
    verdict = decide(measured=measured, predicted_pk_pk_pu=0.05, rule=rule)
    assert verdict.upper_limit_pu - 0.05 == pytest.approx(0.002 + 0.005)


def test_wrong_signature_fails_even_when_magnitude_matches(measured):
    rule = DecisionRule(rel_tol=0.5)
    verdict = decide(measured=measured, predicted_pk_pk_pu=measured.pk_pk_pu,
                     predicted_order=2, rule=rule)
    assert verdict.magnitude_decision == "pass"
    assert verdict.decision == "fail"
    assert verdict.signature_ok is False and not verdict.guarded_pass
    assert "signature" in verdict.reason


def test_power_share_rule_accepts_a_non_dominant_order(measured):
    share = measured.order_power_share(1)
    assert 0.0 < share < 0.5
    loose = DecisionRule(rel_tol=0.5, min_order_share=share / 2)
    strict = DecisionRule(rel_tol=0.5, min_order_share=min(1.0, share * 2))
    kwargs = {"measured": measured, "predicted_pk_pk_pu": measured.pk_pk_pu, "predicted_order": 1}
    assert decide(rule=loose, **kwargs).decision == "pass"
    assert decide(rule=strict, **kwargs).decision == "fail"
    unchecked = decide(rule=DecisionRule(rel_tol=0.5, check_signature=False), **kwargs)
    assert unchecked.decision == "pass" and unchecked.signature_ok is None


def test_classify_limits_are_inclusive():
    assert classify(1.0, 0.1, 0.9, 1.1) == "pass"
    assert classify(1.0, 0.2, 0.9, 1.1) == "conditional pass"
    assert classify(1.25, 0.2, 0.9, 1.1) == "conditional fail"
    assert classify(0.5, 0.2, 0.9, 1.1) == "fail"
    assert set(DECISIONS) == {"pass", "conditional pass", "conditional fail", "fail"}


def test_bad_rule_and_prediction_are_input_errors(measured):
    with pytest.raises(InputError, match="rel_tol"):
        DecisionRule(rel_tol=-0.1)
    with pytest.raises(InputError, match="abs_tol_pu"):
        DecisionRule(rel_tol=0.0, abs_tol_pu=0.0)
    with pytest.raises(InputError, match="predicted_pk_pk_pu"):
        decide(measured=measured, predicted_pk_pk_pu=float("nan"))
    with pytest.raises(InputError, match="predicted_order"):
        decide(measured=measured, predicted_pk_pk_pu=0.04, predicted_order=99)


def test_a_result_without_its_uncertainty_budget_cannot_be_judged():
    time_s = np.arange(8_000) / 20_000.0
    angle = speed_profile_angle(time_s, electrical_hz=40.0, variation=0.0)
    torque = ripple(angle, 1.0, {6: (0.02, 0.3)})
    res = analyze_torque(time_s, torque, angle, max_order=32, uncertainty_budget=False)
    with pytest.raises(InputError, match="without its uncertainty budget"):
        decide(res, 0.04)
