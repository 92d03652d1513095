"""A pure order-k ripple of known amplitude and phase is recovered within 0.5 %."""

from __future__ import annotations

import numpy as np
import pytest

from analysis_synthetic import TWO_PI, ripple, speed_profile_angle
from hil.analysis import analyze_capture, analyze_torque
from hil.capture import Capture

SAMPLE_RATE_HZ = 20_000.0
MEAN_NM = 1.2


def _record(duration_s: float = 1.0) -> np.ndarray:
    return np.arange(int(SAMPLE_RATE_HZ * duration_s)) / SAMPLE_RATE_HZ


@pytest.mark.parametrize("variation", [0.0, 0.05], ids=["constant speed", "±5 % speed"])
@pytest.mark.parametrize("order,amplitude_nm,phase_rad", [
    (1, 0.03, -2.0), (2, 0.02, 1.1), (6, 0.01, 0.7), (36, 0.008, -1.0)])
def test_pure_order_recovered(variation, order, amplitude_nm, phase_rad):
    time_s = _record()
    angle = speed_profile_angle(time_s, electrical_hz=40.0, variation=variation)
    torque = ripple(angle, MEAN_NM, {order: (amplitude_nm, phase_rad)})
    res = analyze_torque(time_s, torque, angle, max_order=48, named_order=order)
    assert res.dominant_order == order
    assert res.named_amplitude_nm == pytest.approx(amplitude_nm, rel=0.005)
    assert abs(np.angle(np.exp(1j * (res.named_phase_rad - phase_rad)))) < 0.005
    assert res.mean_torque_nm == pytest.approx(MEAN_NM, rel=1e-4)
    assert res.pk_pk_nm == pytest.approx(2 * amplitude_nm, rel=0.005)
    assert res.pk_pk_pu == pytest.approx(2 * amplitude_nm / MEAN_NM, rel=0.005)
    assert res.rms_ac_nm == pytest.approx(amplitude_nm / np.sqrt(2), rel=0.005)
    others = np.delete(res.amplitude_nm, order - 1)
    assert others.max() < 0.005 * amplitude_nm


def test_two_orders_and_waveform_on_grid():
    time_s = _record()
    angle = speed_profile_angle(time_s, electrical_hz=25.0, variation=0.05)
    content = {6: (0.02, 0.4), 12: (0.005, -2.5)}
    res = analyze_torque(time_s, ripple(angle, MEAN_NM, content), angle, max_order=32)
    expected = ripple(res.angle_grid_rad, MEAN_NM, content)
    np.testing.assert_allclose(res.sync_average_nm, expected, atol=2e-4 * 0.02)
    assert res.revolution_matrix_nm.shape == (res.revolutions, res.samples_per_rev)
    assert res.order_power_share(6) == pytest.approx(0.02 ** 2 / (0.02 ** 2 + 0.005 ** 2), rel=1e-3)


def test_record_of_7_3_revolutions_uses_whole_revolutions():
    electrical_hz = 50.0
    time_s = _record(7.3 / electrical_hz)
    angle = speed_profile_angle(time_s, electrical_hz, start_rad=0.0)
    res = analyze_torque(time_s, ripple(angle, MEAN_NM, {2: (0.02, 0.5)}), angle, max_order=16,
                         named_order=2)
    assert res.revolutions == 7
    assert res.named_amplitude_nm == pytest.approx(0.02, rel=0.005)
    assert abs(res.named_phase_rad - 0.5) < 0.005


def test_negative_speed_and_wrapped_mechanical_angle_keep_phase():
    """Phases refer to the electrical angle itself, whichever way the rotor turns."""
    time_s = _record()
    pole_pairs = 2
    angle = -speed_profile_angle(time_s, electrical_hz=30.0, variation=0.05)
    torque = ripple(angle, -MEAN_NM, {1: (0.03, 0.9), 6: (0.01, -0.3)})
    capture = Capture({"time_s": time_s, "torque_nm": torque,
                       "rotor_angle_mech_rad": np.mod(angle / pole_pairs, TWO_PI)},
                      meta={"pole_pairs": pole_pairs})
    res = analyze_capture(capture, max_order=16, named_order=6)
    assert res.direction == -1
    assert res.mean_torque_nm == pytest.approx(-MEAN_NM, rel=1e-4)
    assert res.amplitude_nm[0] == pytest.approx(0.03, rel=0.005)
    assert abs(res.phase_rad[0] - 0.9) < 0.005
    assert res.named_amplitude_nm == pytest.approx(0.01, rel=0.005)
    assert abs(res.named_phase_rad + 0.3) < 0.005


def test_slow_stepping_with_encoder_counts():
    """Near-zero speed, angle from a 7200-count encoder (0.1 electrical deg per count), the rotor
    creeping and pausing: resampling on angle still recovers the ripple."""
    pole_pairs, counts_per_rev = 2, 7200
    time_s = np.arange(200_000) / 10_000.0                    # 20 s
    speed = 0.6 * (1.0 + np.sin(TWO_PI * 2.0 * time_s)) ** 2  # electrical rad/s, stops each 0.5 s
    true_angle = np.concatenate(([0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) / 10_000.0)))
    content = {6: (0.02, 0.7), 36: (0.01, -1.0)}
    torque = ripple(true_angle, MEAN_NM, content)
    counts = np.floor(true_angle / pole_pairs / TWO_PI * counts_per_rev)
    capture = Capture({"time_s": time_s, "torque_nm": torque, "encoder_counts": counts},
                      meta={"pole_pairs": pole_pairs, "encoder_counts_per_rev": counts_per_rev})
    res = analyze_capture(capture, max_order=48, named_order=36)
    assert res.revolutions >= 2
    assert res.amplitude_nm[5] == pytest.approx(0.02, rel=0.005)
    assert abs(res.phase_rad[5] - 0.7) < 0.01
    assert res.named_amplitude_nm == pytest.approx(0.01, rel=0.005)
    # half a count (0.05 electrical deg) of floor-quantisation offset is 1.8 deg at order 36
    assert abs(res.named_phase_rad + 1.0) < np.deg2rad(2.5)


def test_angle_from_speed_channel_gives_amplitude():
    time_s = _record()
    angle = speed_profile_angle(time_s, electrical_hz=40.0, variation=0.05, start_rad=0.0)
    speed_rpm = np.gradient(angle, time_s) / 2 / TWO_PI * 60.0
    capture = Capture({"time_s": time_s, "torque_nm": ripple(angle, MEAN_NM, {6: (0.01, 0.2)}),
                       "speed_rpm": speed_rpm}, meta={"pole_pairs": 2})
    res = analyze_capture(capture, max_order=16, named_order=6)
    assert res.named_amplitude_nm == pytest.approx(0.01, rel=0.005)


def _encoder_ripple_capture(noise_nm=0.0, seed=0):
    """The paper's encoder effect (eqs 7-9) synthesised directly: the firmware places the current
    at the angle quantised to 10 electrical degrees, so torque ∝ cos(γ) with γ the angle since the
    last step; the rotor turns slowly (1 electrical rev/s), the angle is read from 7200 counts."""
    pole_pairs, counts_per_rev, resolution_rad = 2, 7200, np.deg2rad(10.0)
    time_s = np.arange(70_000) / 20_000.0
    true_angle = TWO_PI * 1.0 * time_s * (1 + 0.05 * np.sin(TWO_PI * 0.4 * time_s))
    gamma = np.mod(true_angle, resolution_rad)
    torque = MEAN_NM * np.cos(gamma)
    torque += np.random.default_rng(seed).normal(0.0, noise_nm, time_s.size)
    counts = np.floor(true_angle / pole_pairs / TWO_PI * counts_per_rev)
    capture = Capture({"time_s": time_s, "torque_nm": torque, "encoder_counts": counts},
                      meta={"pole_pairs": pole_pairs, "encoder_counts_per_rev": counts_per_rev})
    true_pk_pk_pu = (1.0 - np.cos(resolution_rad)) / np.mean(np.cos(np.linspace(
        0.0, resolution_rad, 100_001)))
    return capture, true_pk_pk_pu


def test_step_shaped_encoder_ripple_needs_the_bins_method():
    capture, true_pu = _encoder_ripple_capture()
    bins = analyze_capture(capture, max_order=360, named_order=36, pk_pk_method="bins")
    assert bins.dominant_order == 36
    assert bins.pk_pk_pu == pytest.approx(true_pu, rel=0.02)
    assert np.ptp(bins.sync_average_nm) == pytest.approx(bins.pk_pk_nm)
    # the Fourier series of a step overshoots (Gibbs): the band-limited reading is too high
    limited = analyze_capture(capture, max_order=360, pk_pk_method="band-limited")
    assert limited.pk_pk_pu > 1.05 * true_pu


def test_bins_method_noise_bias_within_uncertainty():
    capture, true_pu = _encoder_ripple_capture(noise_nm=0.005, seed=3)
    res = analyze_capture(capture, max_order=360, pk_pk_method="bins")
    assert res.uncertainty.noise_bias_pu > 0
    assert abs(res.pk_pk_pu - true_pu) <= res.uncertainty.expanded_pu
