"""DC offset (eqs 15-20) and gain mismatch (eqs 21-26) against the numerical torque sum."""

import math

import numpy as np
import pytest

from hil.model import OperatingPoint, predict
from hil.model import dc_offset, gain_mismatch
from model_torque_sum import balanced, pk_pk_over_mean, torque_nm

THETA = np.linspace(0, 2 * math.pi, 7200, endpoint=False)


def regulated_currents(op, *, theta=THETA, offsets_a=(0.0, 0.0), gain_errors_pu=(0.0, 0.0)):
    """Actual currents when the *measured* a, b currents follow the sinusoidal command exactly."""
    command = balanced(theta, op.current_a, op.current_angle_rad)
    ia = (command[0] - offsets_a[0]) / (1 + gain_errors_pu[0])
    ib = (command[1] - offsets_a[1]) / (1 + gain_errors_pu[1])
    return np.array([ia, ib, -(ia + ib)])


@pytest.mark.parametrize("offsets", [(0.2, 0.0), (0.0, -0.3), (0.2, 0.2), (0.25, -0.1), (-0.4, 0.15)])
@pytest.mark.parametrize("phi_deg", [0.0, 30.0, -20.0])
def test_dc_offset_matches_torque_sum(offsets, phi_deg):
    op = OperatingPoint(speed_rpm=500, current_a=20.0, current_angle_rad=math.radians(phi_deg))
    pred = predict("dc_offset", op, ia_offset_a=offsets[0], ib_offset_a=offsets[1])
    torque = torque_nm(THETA, regulated_currents(op, offsets_a=offsets))
    assert pred.pk_pk_pu == pytest.approx(pk_pk_over_mean(torque), rel=1e-4)
    assert pred.base_nm == pytest.approx(np.mean(torque), rel=1e-6)
    on_grid = torque_nm(pred.angle_rad, regulated_currents(op, theta=pred.angle_rad, offsets_a=offsets))
    assert np.max(np.abs(pred.waveform_pu - (on_grid / np.mean(on_grid) - 1))) < 1e-6
    assert pred.order == 1.0


def test_dc_offset_paper_figure_one_percent_worst_case_is_four_percent():
    op = OperatingPoint(speed_rpm=0, current_a=10.0)
    pred = predict("dc_offset", op, offset_a_pu=0.01, offset_b_pu=0.01)
    assert pred.pk_pk_pu == pytest.approx(0.04, rel=1e-9)
    # eq 20 is the worst case: no combination within ±1 % does worse (numerical torque sum)
    worst = max(pk_pk_over_mean(torque_nm(THETA, regulated_currents(op, offsets_a=(a, b))))
                for a in np.linspace(-0.1, 0.1, 9) for b in np.linspace(-0.1, 0.1, 9))
    assert worst == pytest.approx(dc_offset.worst_case_pk_pk_pu(0.01), rel=1e-4)


@pytest.mark.parametrize("gains", [(0.01, -0.01), (0.05, 0.0), (0.0, -0.1), (0.1, 0.1), (-0.15, 0.08)])
@pytest.mark.parametrize("phi_deg", [0.0, 25.0, -40.0])
def test_gain_mismatch_matches_torque_sum(gains, phi_deg):
    op = OperatingPoint(speed_rpm=800, current_a=30.0, current_angle_rad=math.radians(phi_deg))
    pred = predict("gain_mismatch", op, ia_gain_error_pu=gains[0], ib_gain_error_pu=gains[1])
    torque = torque_nm(THETA, regulated_currents(op, gain_errors_pu=gains))
    assert pred.pk_pk_pu == pytest.approx(pk_pk_over_mean(torque), rel=1e-4, abs=1e-12)
    assert pred.base_nm == pytest.approx(np.mean(torque), rel=1e-9)
    on_grid = torque_nm(pred.angle_rad,
                        regulated_currents(op, theta=pred.angle_rad, gain_errors_pu=gains))
    assert np.max(np.abs(pred.waveform_pu - (on_grid / np.mean(on_grid) - 1))) < 1e-6
    assert pred.order == 2.0


def test_gain_mismatch_paper_figure_one_percent_is_2_31_percent():
    op = OperatingPoint(speed_rpm=300, current_a=15.0)
    pred = predict("gain_mismatch", op, ia_gain_error_pu=0.01, ib_gain_error_pu=-0.01)
    assert round(100 * pred.pk_pk_pu, 2) == 2.31
    assert pred.pk_pk_pu == pytest.approx(4 / math.sqrt(3) * 0.01, rel=1e-9)  # eq 26, exact here
    worst = max(pk_pk_over_mean(torque_nm(THETA, regulated_currents(op, gain_errors_pu=(a, b))))
                for a in np.linspace(-0.01, 0.01, 5) for b in np.linspace(-0.01, 0.01, 5))
    assert worst == pytest.approx(gain_mismatch.worst_case_pk_pk_pu(0.01), rel=1e-4)


def test_equal_gains_give_no_ripple():
    op = OperatingPoint(speed_rpm=300, current_a=15.0)
    assert predict("gain_mismatch", op, ia_gain_error_pu=0.05,
                   ib_gain_error_pu=0.05).pk_pk_pu == pytest.approx(0.0, abs=1e-15)
