"""The PWM-resolution plan's sweep scale (issue 30 item 4): a model 2x too large passed the
per-point [1/3, 3]x range; the sweep's geometric-mean ratio, banded from the calibration set,
fails it (end to end: studies/mutation_table.py's "pwm_resolution model x2" row)."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from ripple_hil_testplans import test_pwm_resolution as plan

#: measured/predicted pk-pk of the calibration and holdout sweeps (studies/pwm_calibration.py,
#: hil/model/README.md "PWM resolution: the sweep's scale"), one tuple per run (C = 32, 64, 128)
CALIBRATION = [(0.867, 0.674, 0.763), (0.408, 0.842, 0.686), (0.952, 0.565, 0.802),
               (0.474, 0.880, 0.863)]
HOLDOUT = [(0.530, 0.928, 0.933), (0.519, 0.801, 0.917), (0.435, 0.610, 0.681),
           (0.836, 0.822, 0.698), (0.837, 0.823, 0.671), (0.301, 1.587, 0.465),
           (0.318, 1.435, 0.511)]


def record_of(ratios, model_factor=1.0):
    tests = [{"source": "pwm_resolution", "verdict": {"measured_pk_pk_pu": 0.01 * r,
                                                      "predicted_pk_pk_pu": 0.01 * model_factor}}
             for r in ratios]
    tests.append({"source": "pwm_resolution", "verdict": None})          # the noise reference
    return SimpleNamespace(tests=tests, set_section=lambda name, data: None)


@pytest.mark.parametrize("ratios", CALIBRATION + HOLDOUT)
def test_a_correct_sweep_passes_and_a_model_twice_too_large_fails(ratios):
    plan.test_pwm_resolution_scale(record_of(ratios))
    with pytest.raises(AssertionError, match="pwm_resolution scale"):
        plan.test_pwm_resolution_scale(record_of(ratios, model_factor=2.0))


def test_the_per_point_range_could_not_fail_it():
    """The old verdict: each point within [1/3, 3]x of the model; a 2x model keeps most points
    inside (the hole)."""
    inside = [r / 2.0 >= 1.0 / 3.0 for run in CALIBRATION + HOLDOUT for r in run]
    assert sum(inside) > len(inside) / 2


def test_too_few_points_are_not_determinable():
    with pytest.raises(pytest.skip.Exception, match="not determinable"):
        plan.test_pwm_resolution_scale(record_of([0.7]))
