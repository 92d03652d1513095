"""Encoder resolution (eqs 7-9) and CPU word length (eqs 10-14) against numerical evaluation."""

import math

import numpy as np
import pytest

from hil.errors import InputError
from hil.model import OperatingPoint, predict
from hil.model.encoder import PAPER_FIG3_CURRENT_ANGLE_RAD, current_angle_for_ripple
from model_torque_sum import balanced, pk_pk_over_mean, torque_nm

FINE = np.linspace(0, 2 * math.pi, 72000, endpoint=False)


def staircase_torque(op, resolution_rad, theta=FINE):
    """Currents commanded from the angle truncated to the last count (ideal regulation)."""
    theta_d = np.floor(theta / resolution_rad + 1e-9) * resolution_rad
    return torque_nm(theta, balanced(theta_d, op.current_a, op.current_angle_rad))


@pytest.mark.parametrize("decimation", [1, 20, 100, 300])
@pytest.mark.parametrize("phi_deg", [0.0, 10.0, 45.0, -30.0])
def test_encoder_matches_torque_sum(decimation, phi_deg):
    op = OperatingPoint(speed_rpm=0, current_a=20.0, current_angle_rad=math.radians(phi_deg))
    pred = predict("encoder", op, encoder_decimation=decimation)
    resolution = 2 * math.pi * 2 * decimation / 7200
    assert pred.inputs["resolution_elec_rad"] == pytest.approx(resolution)
    # eq 8 says the torque repeats every count: 36 counts at 5000 samples each are enough
    theta = np.linspace(0, 36 * resolution, 36 * 5000, endpoint=False)
    torque = staircase_torque(op, resolution, theta)
    assert pred.pk_pk_pu == pytest.approx(pk_pk_over_mean(torque), rel=1e-3)
    assert pred.base_nm == pytest.approx(np.mean(torque), rel=1e-4)
    assert pred.order == pytest.approx(3600 / decimation)
    on_grid = staircase_torque(op, resolution, pred.angle_rad)
    assert np.allclose(pred.base_nm * (1 + pred.waveform_pu), on_grid, rtol=1e-9)


def test_hall_mode_is_sixty_degrees():
    op = OperatingPoint(speed_rpm=100, current_a=10.0)
    pred = predict("encoder", op, hall_mode=True, encoder_decimation=1)
    assert pred.inputs["resolution_elec_deg"] == pytest.approx(60.0)
    assert pred.order == pytest.approx(6.0)
    assert pred.pk_pk_pu == pytest.approx(pk_pk_over_mean(staircase_torque(op, math.pi / 3)),
                                          rel=2e-3)


def test_paper_figure_3_ten_degrees_gives_4_5_percent_at_phi_10_degrees():
    op = OperatingPoint(speed_rpm=0, current_a=20.0, current_angle_rad=PAPER_FIG3_CURRENT_ANGLE_RAD)
    pred = predict("encoder", op, resolution_elec_rad=math.radians(10.0))
    assert round(100 * pred.extras["paper_pk_pk_pu"], 1) == 4.5
    # per unit of (3/2)·E·I/ω_m, straight from the torque sum
    torque = staircase_torque(op, math.radians(10.0))
    assert np.ptp(torque) / (op.motor.torque_constant_nm_per_a * op.current_a) == pytest.approx(
        pred.extras["paper_pk_pk_pu"], rel=2e-3)
    assert predict("encoder", OperatingPoint(speed_rpm=0, current_a=20.0),
                   resolution_elec_rad=math.radians(10)).extras["paper_pk_pk_pu"] < 0.016


def lsb_truncate(x, bits):
    """Two's-complement truncation of a per-unit value to n bits (toward −∞)."""
    lsb = 2.0 ** -(bits - 1)
    return np.floor(np.asarray(x) / lsb) * lsb


def fixed_point_iq(theta, current_pu, bits):
    """I_q as an n-bit CPU computes it (eq 10 with the sin projection of i_a = I·sin θ)."""
    table = lsb_truncate(balanced(theta), bits)
    currents = lsb_truncate(balanced(theta, current_pu), bits)
    return lsb_truncate(2 / 3 * np.sum(currents * table, axis=0), bits)


@pytest.mark.parametrize("bits", [8, 10, 12, 16])
@pytest.mark.parametrize("current_a", [10.0, 50.0, 99.0])
def test_word_length_bound_holds_for_real_truncation(bits, current_a):
    op = OperatingPoint(speed_rpm=100, current_a=current_a)  # 99 A: within 12 V below ~430 rpm
    pred = predict("word_length", op, word_length_bits=bits)
    theta = np.linspace(0, 2 * math.pi, 20000, endpoint=False)
    iq_error = fixed_point_iq(theta, current_a / 100.0, bits) - current_a / 100.0
    # ideal regulation drives the computed I_q to the command: actual current off by −I_max·ΔI_q
    actual = balanced(theta, current_a - 100.0 * iq_error)
    ripple = pk_pk_over_mean(torque_nm(theta, actual))
    assert 0 < ripple <= pred.extras["balanced_bound_pk_pk_pu"] <= pred.pk_pk_pu


@pytest.mark.parametrize("bits", [8, 12, 16])
def test_word_length_worst_case_sign_pattern_reaches_the_balanced_bound(bits):
    """Every error at one LSB with the sign that adds (exact products, not linearised)."""
    current_pu = 0.9
    op = OperatingPoint(speed_rpm=500, current_a=100.0 * current_pu)
    pred = predict("word_length", op, word_length_bits=bits)
    lsb = 2.0 ** -(bits - 1)
    theta = np.array([math.pi / 2])  # Σ|sin θ_x| = 2 here
    table, currents = balanced(theta)[:, 0], balanced(theta, current_pu)[:, 0]
    extremes = []
    for sign in (+1, -1):
        iq = 2 / 3 * np.sum((currents + sign * lsb * np.sign(table))
                            * (table + sign * lsb * np.sign(currents))) + sign * lsb
        extremes.append(iq - current_pu)
    torque_pk_pk = np.ptp([torque_nm(theta, balanced(theta, 100 * (current_pu - e)))[0]
                           for e in extremes])
    ripple = torque_pk_pk / (op.motor.torque_constant_nm_per_a * op.current_a)
    assert ripple == pytest.approx(pred.extras["balanced_bound_pk_pk_pu"], rel=1e-3)
    assert ripple < pred.pk_pk_pu  # the paper's 10/2^(n-1) is conservative (6 terms cannot align)


def test_word_length_paper_formula_and_conversion():
    op = OperatingPoint(speed_rpm=500, current_a=25.0, current_angle_rad=math.radians(30))
    pred = predict("word_length", op, word_length_bits=12)
    assert pred.extras["paper_pk_pk_pu"] == 10 / 2 ** 11
    assert pred.pk_pk_pu == pytest.approx(10 / 2 ** 11 * 100 / (25 * math.cos(math.radians(30))))
    assert pred.order is None


def test_encoder_minimum_inside_the_count_phi_80_resolution_120():
    """γ + φ passes π inside the count: the minimum of cos is −1 (issue 13 item 7)."""
    op = OperatingPoint(speed_rpm=0, current_a=20.0, current_angle_rad=math.radians(80))
    pred = predict("encoder", op, resolution_elec_rad=math.radians(120))
    assert pred.extras["paper_pk_pk_pu"] == pytest.approx(1 + math.cos(math.radians(80)))
    assert round(pred.extras["paper_pk_pk_pu"], 3) == 1.174
    torque = staircase_torque(op, math.radians(120))  # mean torque negative here
    assert np.mean(torque) < 0 and pred.extras["mean_torque_sign"] == -1.0
    assert pred.pk_pk_pu > 0 and pred.base_nm > 0
    assert pred.pk_pk_pu == pytest.approx(np.ptp(torque) / abs(np.mean(torque)), rel=1e-3)
    assert pred.base_nm == pytest.approx(abs(np.mean(torque)), rel=1e-4)


@pytest.mark.parametrize("resolution_deg,target_pct", [(10.0, 4.68), (10.0, 20.0), (60.0, 80.0),
                                                       (2.5, 1.0)])
def test_encoder_current_angle_for_a_target_ripple(resolution_deg, target_pct):
    res = math.radians(resolution_deg)
    phi = current_angle_for_ripple(res, target_pct / 100)
    assert 0.0 <= phi < math.pi / 2
    op = OperatingPoint(speed_rpm=0, current_a=20.0, current_angle_rad=phi)
    theta = np.linspace(0, 6 * res, 6 * 20000, endpoint=False)  # eq 8: periodic in the count
    torque = staircase_torque(op, res, theta)  # independent of the inversion: the torque sum
    assert pk_pk_over_mean(torque) == pytest.approx(target_pct / 100, rel=2e-3)


def test_encoder_target_below_the_lagging_branch_is_refused():
    with pytest.raises(InputError, match="unreachable on the lagging branch"):
        current_angle_for_ripple(math.radians(10.0), 0.01)
