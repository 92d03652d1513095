"""The order-phase verdict (``hil.analysis.decision.decide_phase``) on synthetic torque of known
phase: it passes the right phase, fails a phase moved by the amount a wrong sensor or sign moves
it, needs the order resolved, and follows the sign of the mean torque."""

from __future__ import annotations

import math

import numpy as np
import pytest

from analysis_synthetic import ripple
from hil.analysis import analyze_torque
from hil.analysis.decision import decide_phase, measured_order_phase
from hil.errors import InputError

RATE_HZ, ELECTRICAL_HZ, REVOLUTIONS = 4000.0, 20.0, 8


def result(mean_nm: float, orders: dict, noise_nm: float = 1e-4, direction: int = 1, seed=1):
    time_s = np.arange(int(RATE_HZ * REVOLUTIONS / ELECTRICAL_HZ)) / RATE_HZ
    angle = 0.4 + direction * 2 * math.pi * ELECTRICAL_HZ * time_s
    torque = ripple(angle, mean_nm, orders)
    torque += np.random.default_rng(seed).normal(0.0, noise_nm, time_s.size)
    return analyze_torque(time_s, torque, angle, max_order=8)


@pytest.mark.parametrize("direction", [1, -1])
def test_the_right_phase_passes_and_a_moved_phase_fails(direction):
    measured = result(1.0, {1: (0.02, 1.05)}, direction=direction)
    ok = decide_phase(measured, 1, 1.05, tolerance_rad=0.2)
    assert ok.decision == "pass" and ok.guarded_pass
    assert abs(ok.difference_rad) < 0.01 and ok.measured_u_rad < 0.02
    # the other sensor (60 degrees away) and the other sign (pi away) fail
    for predicted in (1.05 - math.pi / 3, 1.05 + math.pi / 3, 1.05 - math.pi):
        moved = decide_phase(measured, 1, predicted, tolerance_rad=0.2)
        assert moved.decision == "fail" and not moved.guarded_pass, moved.reason


def test_the_phase_difference_wraps_across_pi():
    measured = result(1.0, {2: (0.02, math.pi - 0.02)})
    verdict = decide_phase(measured, 2, -math.pi + 0.02, tolerance_rad=0.1)
    assert verdict.difference_rad == pytest.approx(-0.04, abs=0.01) and verdict.guarded_pass


def test_guard_band_makes_a_marginal_phase_conditional():
    measured = result(1.0, {1: (0.002, 0.5)}, noise_nm=2e-3)
    _, u_phase, _ = measured_order_phase(measured, 1)
    assert u_phase > 0.05
    phase = measured_order_phase(measured, 1)[0]
    inside = decide_phase(measured, 1, phase - (0.15 - u_phase / 2), tolerance_rad=0.15)
    assert inside.decision == "conditional pass" and not inside.guarded_pass
    outside = decide_phase(measured, 1, phase - (0.15 + u_phase / 2), tolerance_rad=0.15)
    assert outside.decision == "conditional fail" and not outside.guarded_pass


def test_an_order_that_is_not_resolved_has_no_phase_and_fails():
    measured = result(1.0, {1: (0.02, 0.3)}, noise_nm=1e-3)
    verdict = decide_phase(measured, 3, 0.3, tolerance_rad=0.2)
    assert verdict.decision == "fail" and "not resolved" in verdict.reason


def test_a_negative_mean_torque_turns_the_per_unit_phase_by_pi():
    measured = result(-1.0, {1: (0.02, 0.3)})
    phase, _, _ = measured_order_phase(measured, 1)
    assert phase == pytest.approx(0.3 - math.pi, abs=0.01)


def test_bad_inputs_are_refused():
    measured = result(1.0, {1: (0.02, 0.3)})
    with pytest.raises(InputError):
        decide_phase(measured, 1, 0.3, tolerance_rad=0.0)
    with pytest.raises(InputError):
        decide_phase(measured, 9, 0.3, tolerance_rad=0.2)


def test_the_point_verdict_is_the_worse_of_magnitude_and_phase():
    from hil.analysis import decide
    from hil.analysis.decision import with_phase

    measured = result(1.0, {1: (0.02, 1.05)})
    magnitude = decide(measured, 0.04, 1)
    assert magnitude.decision == "pass"
    wrong = with_phase(magnitude, decide_phase(measured, 1, 1.05 - math.pi / 3, tolerance_rad=0.2))
    assert wrong.decision == "fail" and not wrong.guarded_pass
    assert wrong.magnitude_decision == "pass" and "phase" in wrong.reason
    right = with_phase(magnitude, decide_phase(measured, 1, 1.05, tolerance_rad=0.2))
    assert right.decision == "pass" and right.guarded_pass
    assert with_phase(magnitude, None) is magnitude


def test_the_plans_phase_judge_corrects_for_the_stated_transducer_and_needs_it():
    """``ripple_hil_testplans.phase``: the model phase moved by the stated transducer's lag is
    what passes; a bench file without a transducer bandwidth gets no phase verdict."""
    from types import SimpleNamespace

    from hil.config import default_sim_bench
    from hil.model import OperatingPoint, predict
    from ripple_hil_testplans.phase import phase_judge

    config = default_sim_bench()
    pole_pairs = config.motor.pole_pairs
    speed_rpm = ELECTRICAL_HZ * 60.0 / pole_pairs
    op = OperatingPoint(speed_rpm=speed_rpm, current_a=20.0, motor=config.motor)
    prediction = predict("dc_offset", op, ia_offset_a=0.2)
    model_phase = prediction.extras["order_phase_rad"]
    lag = math.atan(ELECTRICAL_HZ / config.torque.bandwidth_hz)
    plan = SimpleNamespace(speed_rpm=speed_rpm)
    judge = phase_judge(0.2)
    lagging = result(1.0, {1: (0.02, model_phase - lag)})
    verdict = judge(lagging, prediction, plan, SimpleNamespace(config=config))
    assert verdict.guarded_pass and abs(verdict.difference_rad) < 0.01
    assert verdict.tolerance_rad == pytest.approx(math.asin(0.2) + lag + math.atan(
        ELECTRICAL_HZ / 1600.0) + 2 * math.pi * ELECTRICAL_HZ * 75e-6 + math.pi * pole_pairs
        / 7200, rel=1e-6)
    other_sensor = result(1.0, {1: (0.02, model_phase - math.pi / 3)})
    assert not judge(other_sensor, prediction, plan, SimpleNamespace(config=config)).guarded_pass
    unstated = SimpleNamespace(config=SimpleNamespace(
        torque=SimpleNamespace(bandwidth_hz=None), drive=config.drive, motor=config.motor))
    assert judge(lagging, prediction, plan, unstated) is None


def test_the_loop_lag_bound_follows_a_loop_tuned_on_the_nameplate():
    """A drive whose gains came from its nameplate (``loop_tuning``) on a motor measured with
    L 25 % higher crosses over at ωc·L_tuned/L: the loop-lag bound is atan(f/1280 Hz), not
    atan(f/1600 Hz)."""
    from dataclasses import replace
    from types import SimpleNamespace

    from hil.config import default_sim_bench
    from hil.model import predict
    from ripple_hil_testplans.phase import phase_judge

    stated = default_sim_bench()
    plant = replace(stated.motor, phase_resistance_ohm=stated.motor.phase_resistance_ohm * 1.25,
                    phase_inductance_h=stated.motor.phase_inductance_h * 1.25)
    config = replace(stated, motor=plant, loop_tuning=stated.motor)
    speed_rpm = ELECTRICAL_HZ * 60.0 / config.motor.pole_pairs
    prediction = predict("dc_offset", config.model_point(speed_rpm, 20.0), ia_offset_a=0.2)
    lag = math.atan(ELECTRICAL_HZ / config.torque.bandwidth_hz)
    measured = result(1.0, {1: (0.02, prediction.extras["order_phase_rad"] - lag)})
    verdict = phase_judge(0.2)(measured, prediction, SimpleNamespace(speed_rpm=speed_rpm),
                               SimpleNamespace(config=config))
    assert verdict.tolerance_rad == pytest.approx(math.asin(0.2) + lag + math.atan(
        ELECTRICAL_HZ / 1280.0) + 2 * math.pi * ELECTRICAL_HZ * 75e-6 + math.pi
        * config.motor.pole_pairs / 7200, rel=1e-6)


def test_the_plans_phase_judge_uses_the_angle_reference():
    """Issue 30: on motulator's drive the angle channel reads θ₀ = 180° at phase a's back-EMF
    rising zero. With that reference (measured by the self-check, or stated) the order-1 phase
    moved by π passes and the unmoved one fails; with no reference at all there is no phase
    verdict (before, the twin's 0° was assumed and a correct foreign drive failed by π)."""
    from dataclasses import replace
    from types import SimpleNamespace

    from hil.config import default_sim_bench
    from hil.model import OperatingPoint, predict
    from ripple_hil_testplans.phase import phase_judge

    config = default_sim_bench()
    speed_rpm = ELECTRICAL_HZ * 60.0 / config.motor.pole_pairs
    op = OperatingPoint(speed_rpm=speed_rpm, current_a=20.0, motor=config.motor)
    prediction = predict("dc_offset", op, ia_offset_a=0.2)
    lag = math.atan(ELECTRICAL_HZ / config.torque.bandwidth_hz)
    expected = prediction.extras["order_phase_rad"] - lag
    plan = SimpleNamespace(speed_rpm=speed_rpm)
    judge = phase_judge(0.2)
    moved = result(1.0, {1: (0.02, expected - math.pi)})
    unmoved = result(1.0, {1: (0.02, expected)})
    unstated = replace(config, daq=replace(config.daq, emf_a_rising_zero_elec_deg=None))
    measured = SimpleNamespace(config=unstated, angle_reference_meta={
        "emf_a_rising_zero_elec_deg": 180.0, "emf_a_rising_zero_u_elec_deg": 0.5})
    stated = SimpleNamespace(config=replace(config, daq=replace(config.daq,
                                                                emf_a_rising_zero_elec_deg=180.0)))
    for bench in (measured, stated):
        assert judge(moved, prediction, plan, bench).guarded_pass
        assert not judge(unmoved, prediction, plan, bench).guarded_pass
    assert judge(moved, prediction, plan, SimpleNamespace(config=unstated)) is None
