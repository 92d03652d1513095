"""DecisionRule(quantity="named_order_pk_pk"): the predicted order's own pk-pk 2·A_N is judged,
with the U of that amplitude, so a floor spread over other orders cannot move the verdict."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hil.analysis import DecisionRule, analyze_torque, decide
from hil.analysis.decision import named_order_value
from hil.analysis.uncertainty import InstrumentUncertainty
from hil.errors import InputError

RULE = DecisionRule(rel_tol=0.2, abs_tol_pu=0.002, quantity="named_order_pk_pk")
INSTRUMENTS = InstrumentUncertainty(transducer_accuracy_class_pct=0.1,
                                    transducer_full_scale_nm=5.0, daq_lsb_nm=0.0005)


def _capture(order: int = 36, amplitude_nm: float = 0.01, floor_nm: float = 0.0, seed: int = 1):
    """4 revolutions of 1 N·m with a sinusoid at ``order`` and a fixed pattern at other orders
    (the same every revolution) of pk-pk ≈ 6·floor_nm, plus white noise."""
    rng = np.random.default_rng(seed)
    samples = 4 * 4000
    theta = np.arange(samples) * (2 * math.pi / 4000)
    pattern = floor_nm * np.interp(np.mod(theta, 2 * math.pi),
                                   np.linspace(0, 2 * math.pi, 61),
                                   np.r_[rng.standard_normal(60), 0.0])
    torque = (1.0 + amplitude_nm * np.cos(order * theta) + pattern
              + 2e-4 * rng.standard_normal(samples))
    return analyze_torque(np.arange(samples) / 4000.0, torque, theta, max_order=360,
                          pk_pk_method="bins", instruments=INSTRUMENTS)


def test_value_is_twice_the_order_amplitude_with_a_small_u():
    result = _capture()
    value, expanded = named_order_value(result, 36)
    assert value == pytest.approx(0.02, rel=0.01)
    assert 0 < expanded < 0.05 * value


def test_a_floor_at_other_orders_lifts_the_pk_pk_but_not_the_verdict():
    clean, lifted = _capture(), _capture(floor_nm=0.003)
    assert lifted.pk_pk_pu > 1.3 * clean.pk_pk_pu
    for result in (clean, lifted):
        assert decide(result, 0.02, 36, RULE).decision == "pass"
        assert decide(result, 0.04, 36, RULE).decision == "fail"     # a model x2
        assert decide(result, 0.01, 36, RULE).decision == "fail"     # a model x0.5
    # judged on the pk-pk, the lifted capture fails the same 20 % band
    pk_pk_rule = DecisionRule(rel_tol=0.2, abs_tol_pu=0.002)
    assert decide(lifted, 0.02, 36, pk_pk_rule).decision != "pass"


def test_the_rule_needs_a_known_quantity_and_an_order():
    with pytest.raises(InputError, match="quantity"):
        DecisionRule(quantity="rms")
    with pytest.raises(InputError, match="predicted order"):
        decide(_capture(), 0.02, None, RULE)
