"""Finite encoder resolution (paper III-A, eqs 7-9) and Hall sensors (60° electrical).

As in the paper, measured near standstill (the rotor turned slowly by the dyno), with the current
lagging the EMF by φ = 10°, which reproduces the paper's 4.5 % at 10° electrical.
"""

import pytest

from ripple_hil_testplans import conditions as c
from ripple_hil_testplans.sensitivity import check_sensitivity

pytestmark = pytest.mark.ripple_source("encoder")


def plan(config, injection):
    # The ripple is a staircase: its pk-pk is taken from the angle bins ("bins"), on a grid fine
    # enough for the 2.5° steps (order 144) to hold several bins per step.
    return c.point(config.operating_point, "encoder", injection, c.CLOSED_FORM_RULE,
                   speed_rpm=c.ENCODER_SPEED_RPM, current_angle_rad=c.ENCODER_CURRENT_ANGLE_RAD,
                   max_order=360, pk_pk_method="bins", revolutions=4)


@pytest.mark.parametrize("injection", c.ENCODER_SWEEP, ids=c.sweep_id)
def test_encoder_resolution(measure, bench, injection):
    outcome = measure(plan(bench.config, injection))
    assert outcome.passed, outcome.summary()


def test_encoder_sensitivity(record):
    """The sweep's measured ripple scales with the injection as the model says (slope 1)."""
    result = check_sensitivity(record, "encoder", c.CLOSED_FORM_RULE.rel_tol)
    assert result["accepted"], result["statement"]
