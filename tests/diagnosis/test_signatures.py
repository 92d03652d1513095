"""Forward signatures of the diagnosis against the paper's closed forms (hil.model) and against a
direct torque sum; no twin."""

import math

import numpy as np
import pytest

from hil.diagnosis import signatures as sig
from hil.model.dc_offset import ripple_pu
from hil.model.gain_mismatch import current_errors, torque_coefficients

IDEAL = sig.DriveSetup()
LOOP = sig.DriveSetup(current_loop_bandwidth_hz=1600.0, current_loop_delay_s=75e-6,
                      transducer_bandwidth_hz=1000.0)


def _order(waveform: np.ndarray, k: int) -> complex:
    theta = np.arange(waveform.size) * 2 * math.pi / waveform.size
    return complex(2.0 * np.mean(waveform * np.exp(-1j * k * theta)))


@pytest.mark.parametrize("phi_deg", [0.0, 25.0, -40.0])
@pytest.mark.parametrize("offsets", [(0.2, 0.0), (0.0, -0.3), (0.15, 0.1)])
def test_ideal_offset_signature_is_eq19(phi_deg, offsets):
    op = sig.operating_point(500.0, 20.0, math.radians(phi_deg), IDEAL)
    coefficients = (offsets[0] * sig.offset_orders(op, IDEAL, "a")
                    + offsets[1] * sig.offset_orders(op, IDEAL, "b"))
    theta = sig.electrical_grid()
    eq19 = ripple_pu(theta, offsets[0] / op.current_a, offsets[1] / op.current_a,
                     op.current_angle_rad) * op.mean_torque_nm
    assert coefficients[1] == pytest.approx(_order(eq19, 1), rel=1e-9, abs=1e-12)
    assert np.max(np.abs(coefficients[2:])) < 1e-12


@pytest.mark.parametrize("phi_deg", [0.0, 30.0])
def test_ideal_gain_signature_is_eq24(phi_deg):
    op = sig.operating_point(800.0, 15.0, math.radians(phi_deg), IDEAL)
    k1, k2 = current_errors(0.02, -0.01)
    _, amplitude = torque_coefficients(k1, k2, op.current_angle_rad)
    theta = sig.electrical_grid()
    scale = op.motor.emf_peak_v_s_per_rad * op.current_a      # E·I/ω_m
    eq24 = scale * amplitude * np.sin(2 * theta - op.current_angle_rad - 2 * math.pi / 3)
    coefficients = (k1 - k2) * sig.gain_difference_orders(op, IDEAL)
    assert coefficients[2] == pytest.approx(_order(eq24, 2), rel=1e-9)
    assert abs(coefficients[1]) < 1e-12


def test_equal_gain_errors_move_only_the_mean():
    op = sig.operating_point(500.0, 20.0, 0.0, IDEAL)
    coefficients = sig.gain_sum_orders(op, IDEAL)
    assert np.max(np.abs(coefficients[1:])) < 1e-12
    # eq 24: mean (E·I/ω_m)·(3/4)(k1 + k2) per unit k1 + k2 … at φ = 0
    assert coefficients[0].real == pytest.approx(0.75 * op.motor.emf_peak_v_s_per_rad * 20.0)


def test_sensor_error_torque_matches_a_direct_torque_sum():
    """Σ e_x·i_x/ω_m with the actual current errors −n_a, −n_b, +(n_a + n_b) (ideal loop)."""
    op = sig.operating_point(500.0, 20.0, 0.0, IDEAL)
    theta = sig.electrical_grid()
    rng = np.random.default_rng(4)
    n_a = 0.1 * np.cos(3 * theta + rng.uniform(0, 6)) + 0.05
    n_b = 0.07 * np.sin(theta) - 0.02
    coefficients = sig.sensor_error_torque(op, IDEAL, n_a, n_b)
    k_e = op.motor.emf_peak_v_s_per_rad
    direct = k_e * (np.sin(theta) * -n_a + np.sin(theta - 2 * math.pi / 3) * -n_b
                    + np.sin(theta + 2 * math.pi / 3) * (n_a + n_b))
    for k in range(0, 8):
        expected = _order(direct, k) if k else complex(np.mean(direct))
        assert coefficients[k] == pytest.approx(expected, abs=1e-12)


def test_loop_tracks_low_frequencies_and_lags_near_its_bandwidth():
    op = sig.operating_point(500.0, 20.0, 0.0, LOOP)
    assert sig.loop_tracking(0.0, op, LOOP) == 1.0
    assert sig.loop_tracking(123.0, op, IDEAL) == 1.0
    slow = sig.loop_tracking(2 * math.pi * 10.0, op, LOOP)
    fast = sig.loop_tracking(2 * math.pi * 1600.0, op, LOOP)
    assert abs(slow - 1.0) < 0.02
    assert abs(fast - 1.0) > 0.2


def test_loop_moves_the_offset_signature_by_its_tracking_error():
    op = sig.operating_point(1000.0, 20.0, 0.0, LOOP)
    ideal = sig.offset_orders(op, IDEAL, "a")[1]
    looped = sig.offset_orders(op, LOOP, "a")[1]
    # an offset is seen in the rotor frame at −ω_e: the loop's tracking there; the torque takes
    # the current's conjugate (ΔT = (3/2)·k_e·Re(−j·e^{jθ}·Δī*)), so T appears conjugated
    expected = np.conj(sig.loop_tracking(-op.elec_speed_rad_s, op, LOOP))
    assert looped / ideal == pytest.approx(expected, rel=1e-6)


def test_transducer_lags_forward_and_leads_backward():
    forward = sig.transducer_response(12, 1000.0, LOOP)
    backward = sig.transducer_response(12, -1000.0, LOOP)
    assert np.angle(forward) < 0 < np.angle(backward)
    assert backward == pytest.approx(np.conj(forward))
    assert sig.transducer_response(12, 1000.0, IDEAL) == 1.0


def test_dead_time_signature_is_order_6k_and_linear():
    op = sig.operating_point(500.0, 20.0, 0.0, LOOP)
    coefficients = sig.dead_time_orders(op, LOOP)
    big = np.flatnonzero(np.abs(coefficients) > 1e-3 * np.max(np.abs(coefficients)))
    assert all(k % 6 == 0 for k in big) and 6 in big
    # per µs: the model's torque at 2.5 µs has 2.5 times the ripple coefficients (linear in T_d)
    from hil.model.dead_time import average_model_torque_pu

    theta = sig.electrical_grid(sig.DEAD_TIME_GRID_POINTS)
    torque = average_model_torque_pu(theta, op, 2.5e-6, 20000.0, 1600.0, 75e-6)
    at_2p5 = sig.waveform_orders(torque * op.mean_torque_nm)
    assert np.allclose(at_2p5[1:], 2.5 * coefficients[1:], rtol=1e-9, atol=1e-15)


def test_setup_rejects_nonsense():
    with pytest.raises(Exception, match="current_loop_bandwidth_hz"):
        sig.DriveSetup(current_loop_bandwidth_hz=-5.0)
    with pytest.raises(Exception, match="pwm_frequency_hz"):
        sig.DriveSetup(pwm_frequency_hz=100.0)
