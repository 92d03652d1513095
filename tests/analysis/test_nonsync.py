"""hil.analysis.nonsync: the non-synchronous RMS removes the synchronous ripple, keeps the noise
(less the share on the fitted orders), and its type-A uncertainty covers the scatter between
independent captures."""

import math

import numpy as np
import pytest

from hil.analysis.nonsync import nonsynchronous_rms, nonsynchronous_rms_of_capture
from hil.capture import Capture
from hil.errors import InputError

RATE_HZ, F_E_HZ, REVOLUTIONS, MAX_ORDER = 8000.0, 1000.0 / 60.0, 8, 48


def synthetic(noise_nm, seed, sync_nm=0.05):
    """8 electrical revolutions: mean 1 N·m, orders 1, 6 and 30 of sync_nm, white noise."""
    n = int((REVOLUTIONS + 0.25) / F_E_HZ * RATE_HZ)
    time_s = np.arange(n) / RATE_HZ
    angle = 2 * math.pi * F_E_HZ * time_s + 0.3
    sync = sync_nm * (np.cos(angle) + np.sin(6 * angle + 1) + np.cos(30 * angle - 2))
    noise = np.random.default_rng(seed).normal(0.0, noise_nm, n)
    return time_s, 1.0 + sync + noise, np.mod(angle, 2 * math.pi)


def test_synchronous_ripple_is_removed_and_white_noise_kept():
    results = [nonsynchronous_rms(*synthetic(0.002, seed), max_order=MAX_ORDER)
               for seed in range(20)]
    samples = results[0].samples
    # white noise: the fit of 2K + 1 functions keeps (N − 2K − 1)/N of its power
    expected = 0.002 * math.sqrt(1 - (2 * MAX_ORDER + 1) / samples)
    values = np.array([r.rms_nm for r in results])
    assert values.mean() == pytest.approx(expected, rel=0.01)
    # the stated type-A u covers the scatter between independent captures
    u = np.mean([r.rms_u_nm for r in results])
    assert 0.6 < values.std(ddof=1) / u < 1.6
    assert results[0].revolutions == REVOLUTIONS and results[0].mean_torque_nm == \
        pytest.approx(1.0, abs=1e-3)
    # without noise nothing but rounding is left of a 0.15 N·m pk synchronous ripple
    assert nonsynchronous_rms(*synthetic(0.0, 0), max_order=MAX_ORDER).rms_nm < 1e-9


def test_a_synchronous_order_above_max_order_counts_as_non_synchronous():
    time_s, torque, angle = synthetic(0.0, 0, sync_nm=0.0)
    torque = torque + 0.01 * np.cos(60 * np.unwrap(angle))
    assert nonsynchronous_rms(time_s, torque, angle, max_order=48).rms_nm == \
        pytest.approx(0.01 / math.sqrt(2), rel=0.02)
    assert nonsynchronous_rms(time_s, torque, angle, max_order=64).rms_nm < 1e-6


def test_capture_form_and_bad_input():
    time_s, torque, angle = synthetic(0.002, 1)
    capture = Capture(channels={"time_s": time_s, "torque_nm": torque,
                                "rotor_angle_mech_rad": np.mod(angle / 2, 2 * math.pi)})
    direct = nonsynchronous_rms(time_s, torque, angle, max_order=MAX_ORDER)
    assert nonsynchronous_rms_of_capture(capture, pole_pairs=2, max_order=MAX_ORDER).rms_nm == \
        pytest.approx(direct.rms_nm, rel=1e-9)
    with pytest.raises(InputError, match="rotor_angle_mech_rad"):
        nonsynchronous_rms_of_capture(Capture(channels={"time_s": time_s, "torque_nm": torque}),
                                      pole_pairs=2, max_order=MAX_ORDER)
    short = time_s < 1.5 / F_E_HZ
    with pytest.raises(InputError, match="at least 2 whole"):
        nonsynchronous_rms(time_s[short], torque[short], angle[short], max_order=MAX_ORDER)
    with pytest.raises(InputError, match="max_order"):
        nonsynchronous_rms(time_s, torque, angle, max_order=0)
    with pytest.raises(InputError, match="cannot fit orders"):
        nonsynchronous_rms(time_s[::20], torque[::20], angle[::20], max_order=MAX_ORDER)


def test_floor_removal_and_its_uncertainty():
    """floor_removed: the quadrature removal, its U the linear propagation where the value is far
    from 0, and finite where the floor is as large as the point (the inline form of the plan
    divided by max(value, 1e-12) there: U ≈ 1e9 pu printed as '0.000 % ± 1e11 %')."""
    from hil.analysis.nonsync import floor_removed

    # far from 0: the linear form U = k·hypot(raw·u_raw, ref·u_ref)/value
    value, expanded = floor_removed(6e-3, 1e-4, 1e-3, 2e-5, 2e-4)
    floor2 = 1e-3 ** 2 - 2e-4 ** 2
    assert value == pytest.approx(math.sqrt(6e-3 ** 2 - floor2))
    assert expanded == pytest.approx(2 * math.hypot(6e-3 * 1e-4, 1e-3 * 2e-5) / value, rel=0.02)
    # no floor to remove (reference at or below its model): the reference adds no uncertainty
    assert floor_removed(6e-3, 1e-5, 2e-4, 2e-4, 3e-4) == pytest.approx(
        (6e-3, 2 * 1e-5), rel=0.01)
    # the point no noisier than the floor: value 0, U finite and of the order of sqrt(U of value²)
    value, expanded = floor_removed(1e-3, 2e-5, 1.1e-3, 2e-5, 1e-4)
    assert value == 0.0
    u_square = 2 * math.hypot(1e-3 * 2e-5, 1.1e-3 * 2e-5)
    assert expanded == pytest.approx(math.sqrt(2 * u_square))
    with pytest.raises(InputError, match="raw_u=nan"):
        floor_removed(1e-3, math.nan, 1e-3, 1e-5, 1e-4)


def test_synchronous_residual_is_the_least_squares_fit_of_the_fourier_series():
    """The power-sum normal equations give the residual numpy's least squares gives on the
    explicit design matrix (uneven angle steps: a speed ripple), one record or several."""
    from hil.analysis.nonsync import synchronous_residual

    rng = np.random.default_rng(7)
    angle = np.cumsum(rng.uniform(0.5, 1.5, 3000)) * (2 * np.pi * 5 / 3000)
    torque = rng.normal(size=(2, angle.size)) + 1.0 + 0.05 * np.cos(6 * angle)
    orders = np.arange(1, 13)
    design = np.column_stack([np.ones_like(angle), np.cos(np.outer(angle, orders)),
                              np.sin(np.outer(angle, orders))])
    fitted, *_ = np.linalg.lstsq(design, torque.T, rcond=None)
    residual, mean = synchronous_residual(angle, torque, 12)
    np.testing.assert_allclose(residual, torque - (design @ fitted).T, atol=1e-12)
    np.testing.assert_allclose(mean, fitted[0], atol=1e-12)
    one, one_mean = synchronous_residual(angle, torque[0], 12)
    np.testing.assert_allclose(one, residual[0], atol=1e-12)
    assert np.ndim(one_mean) == 0


@pytest.mark.parametrize("per_revolution", [40, 50])
def test_a_fit_the_samples_cannot_resolve_is_refused(per_revolution):
    """40 samples per revolution over 2 revolutions are fewer than the 97 unknowns of order 48;
    50 per revolution are enough in number but alias order k onto 50 − k (review h-27)."""
    from hil.analysis.nonsync import synchronous_residual

    angle = np.arange(2 * per_revolution) * 2 * np.pi / per_revolution
    with pytest.raises(InputError, match="cannot resolve the Fourier series to order 48"):
        synchronous_residual(angle, np.ones_like(angle), 48)
