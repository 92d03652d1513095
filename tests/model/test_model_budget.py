"""The ripple budget: combining sources and inverting a pk-pk specification."""

import math

import numpy as np
import pytest

from hil.errors import InputError
from hil.model import OperatingPoint, predict
from hil.model.budget import DESIGN_SOURCES, combine, combine_sources, invert
from model_torque_sum import balanced, pk_pk_over_mean, torque_nm

OP = OperatingPoint(speed_rpm=1000, current_a=20.0, current_angle_rad=math.radians(10))


def test_combination_rules_and_rebasing():
    preds = [predict("dc_offset", OP, offset_a_pu=0.01),
             predict("gain_mismatch", OP, ia_gain_error_pu=0.01),
             predict("dead_time", OP, dead_time_s=1e-6, nominal_current_a=40.0)]
    combination = combine(OP, preds)
    values = [p.pk_pk_pu * p.base_nm / OP.mean_torque_nm for p in preds]
    assert combination.worst_case_sum_pu == pytest.approx(sum(values))
    assert combination.rss_pu == pytest.approx(math.sqrt(sum(v * v for v in values)))
    # the dead-time figure is per unit of the torque at 40 A; re-based to the 20 A mean torque
    assert combination.contributions_pu["dead_time"] == pytest.approx(
        2 * preds[2].pk_pk_pu / math.cos(OP.current_angle_rad))


def test_worst_case_sum_bounds_the_torque_sum_of_offset_plus_gain():
    """Offset and gain together in the numerical torque sum stay below the worst-case sum."""
    params = {"dc_offset": {"ia_offset_a": 0.2, "ib_offset_a": 0.1},
              "gain_mismatch": {"ia_gain_error_pu": 0.02, "ib_gain_error_pu": -0.01}}
    combination = combine_sources(OP, params)
    theta = np.linspace(0, 2 * math.pi, 7200, endpoint=False)
    command = balanced(theta, OP.current_a, OP.current_angle_rad)
    ia = (command[0] - 0.2) / 1.02
    ib = (command[1] - 0.1) / 0.99
    both = pk_pk_over_mean(torque_nm(theta, np.array([ia, ib, -(ia + ib)])))
    assert combination.rss_pu * 0.9 < both <= combination.worst_case_sum_pu * 1.001


@pytest.mark.parametrize("allocation", ["alone", "equal_sum", "equal_rss"])
def test_inverted_limits_are_the_loosest_that_meet_the_share(allocation):
    spec = invert(OP, 0.02, allocation=allocation)
    share = spec.share_pu
    assert share == pytest.approx({"alone": 0.02, "equal_sum": 0.02 / 7,
                                   "equal_rss": 0.02 / math.sqrt(7)}[allocation])

    def rebased(source, **params):
        return predict(source, OP, **params).pk_pk_nm / OP.mean_torque_nm

    res = spec.limits["encoder"]["resolution_elec_rad"]
    assert rebased("encoder", resolution_elec_rad=res) == pytest.approx(share, rel=1e-6)
    assert rebased("encoder", resolution_elec_rad=1.01 * res) > share
    decimation = spec.limits["encoder"]["encoder_decimation"]
    assert rebased("encoder", encoder_decimation=decimation) <= share
    assert rebased("encoder", encoder_decimation=decimation + 1) > share

    bits = spec.limits["word_length"]["word_length_bits"]
    assert rebased("word_length", word_length_bits=bits, model="derived") <= share
    assert rebased("word_length", word_length_bits=bits - 1, model="derived") > share

    offset = spec.limits["dc_offset"]["offset_a"]
    assert rebased("dc_offset", ia_offset_a=offset, ib_offset_a=offset) == pytest.approx(share)
    assert rebased("dc_offset", ia_offset_a=offset, ib_offset_a=-offset) < share

    gain = spec.limits["gain_mismatch"]["gain_error_pu"]
    worst = max(rebased("gain_mismatch", ia_gain_error_pu=a * gain, ib_gain_error_pu=b * gain)
                for a in (-1, 0, 1) for b in (-1, 0, 1))
    assert worst == pytest.approx(share, rel=1e-6)

    loop = {"current_loop_bandwidth_hz": 1600.0}  # the drive's, assumed when none is given
    assert spec.loop["current_loop_bandwidth_hz"] == 1600.0 and spec.loop["assumed"]
    counts = spec.limits["pwm_resolution"]["pwm_period_counts_min"]
    assert rebased("pwm_resolution", pwm_period_counts=counts, model="closed_loop", **loop) <= share
    assert rebased("pwm_resolution", pwm_period_counts=counts - 1, model="closed_loop",
                   **loop) > share

    switching = spec.limits["pwm_switching"]
    if switching["met"]:
        frequency = switching["pwm_frequency_hz_min"]
        assert rebased("pwm_switching", pwm_frequency_hz=frequency,
                       model="switched_torque") == pytest.approx(share, rel=1e-6)
    else:  # even 50 kHz is too coarse for this share
        assert rebased("pwm_switching", pwm_frequency_hz=50000.0, model="switched_torque") > share

    dead = spec.limits["dead_time"]["dead_time_s"]
    assert rebased("dead_time", dead_time_s=dead, model="average_voltage",
                   current_loop_delay_s=75e-6, **loop) == pytest.approx(share, rel=1e-6)
    assert set(spec.check.contributions_pu) == set(DESIGN_SOURCES)
    assert set(spec.models) == set(DESIGN_SOURCES) and "eq 38" in spec.models["dead_time"]


def test_largest_offset_meets_the_limit_in_the_torque_sum():
    spec = invert(OP, 0.02, allocation="alone")
    offset = spec.limits["dc_offset"]["offset_a"]
    theta = np.linspace(0, 2 * math.pi, 7200, endpoint=False)
    worst = 0.0
    for sa in (-1, 1):
        for sb in (-1, 1):
            command = balanced(theta, OP.current_a, OP.current_angle_rad)
            ia, ib = command[0] - sa * offset, command[1] - sb * offset
            worst = max(worst, pk_pk_over_mean(torque_nm(theta, np.array([ia, ib, -(ia + ib)]))))
    assert worst == pytest.approx(0.02, rel=1e-4)


def test_dead_time_inversion_with_a_stated_loop_and_with_the_paper_forms():
    op = OperatingPoint(speed_rpm=1000, current_a=20.0)
    spec = invert(op, 0.02, allocation="alone", current_loop_bandwidth_hz=1000.0,
                  current_loop_delay_s=0.0)
    assert spec.loop["assumed"] is None
    dead = spec.limits["dead_time"]["dead_time_s"]
    pred = predict("dead_time", op, dead_time_s=dead, model="average_voltage",
                   current_loop_bandwidth_hz=1000.0)
    assert pred.pk_pk_nm / op.mean_torque_nm == pytest.approx(0.02, rel=1e-5)
    paper = invert(op, 0.02, allocation="alone", forms="paper")
    assert paper.limits["dead_time"]["model"] == "paper"
    # eq 38 is well above the closed-loop average model: it allows a much shorter dead time
    assert paper.limits["dead_time"]["dead_time_s"] < 0.6 * dead
    assert paper.models["word_length"].startswith("eq 14")


def test_equal_sum_allocation_meets_the_limit_when_every_share_is_met():
    op = OperatingPoint(speed_rpm=300, current_a=20.0)
    spec = invert(op, 0.2, allocation="equal_sum")
    assert all(limit.get("met", True) for limit in spec.limits.values())
    assert spec.check.worst_case_sum_pu <= 0.2 * (1 + 1e-9)


def test_bad_budget_inputs():
    with pytest.raises(InputError, match="limit_pu"):
        invert(OP, 0.0)
    with pytest.raises(InputError, match="allocation"):
        invert(OP, 0.02, allocation="greedy")
    with pytest.raises(InputError, match="forms"):
        invert(OP, 0.02, forms="mixed")
