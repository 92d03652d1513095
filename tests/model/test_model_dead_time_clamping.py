"""Dead time: the current-clamping model, the voltage loss and the edge-keeping voltage limit."""

import math

import numpy as np
import pytest

from hil.errors import InputError
from hil.model import OperatingPoint, predict
from hil.model.dead_time import (dead_time_linear_voltage_limit_v, dead_time_voltage_command_v,
                                 dead_time_voltage_loss_v)

LOOP = {"current_loop_bandwidth_hz": 1600.0, "current_loop_delay_s": 75e-6}


def test_voltage_loss_is_the_six_step_fundamental():
    # ε = 1 µs · 20 kHz · 12 V = 0.24 V per leg; fundamental (4/π)·ε
    assert dead_time_voltage_loss_v(1e-6, 20_000.0, 12.0) == pytest.approx(0.3056, abs=1e-4)
    assert dead_time_voltage_loss_v(2e-6, 20_000.0, 48.0) == pytest.approx(
        8 * dead_time_voltage_loss_v(1e-6, 20_000.0, 12.0))
    with pytest.raises(InputError):
        dead_time_voltage_loss_v(-1e-6, 20_000.0, 12.0)


def test_edge_keeping_limit_and_command():
    assert dead_time_linear_voltage_limit_v(0.0, 20_000.0, 12.0) == pytest.approx(12 / math.sqrt(3))
    assert dead_time_linear_voltage_limit_v(4e-6, 20_000.0, 12.0) == pytest.approx(
        0.68 * 12 / math.sqrt(3))
    op = OperatingPoint(speed_rpm=1000, current_a=40.0)
    command = dead_time_voltage_command_v(op, 2e-6, 20_000.0)
    assert command == pytest.approx(abs(op.voltage_phasor_peak_v) + 4 / math.pi * 0.48)
    assert command > dead_time_linear_voltage_limit_v(2e-6, 20_000.0, 12.0)   # refused point
    assert dead_time_voltage_command_v(OperatingPoint(speed_rpm=500, current_a=20.0), 4e-6,
                                       20_000.0) < dead_time_linear_voltage_limit_v(
                                           4e-6, 20_000.0, 12.0)


def test_clamping_equals_six_step_where_the_dwell_is_negligible():
    """ε small against the phase voltage (1 µs at 40 A): the dwell at zero is short and the
    current-clamping solution reduces to the six-step series (order 6 within 5 %)."""
    op = OperatingPoint(speed_rpm=500, current_a=40.0)
    clamp = predict("dead_time", op, dead_time_s=1e-6, model="current_clamping", **LOOP)
    six = predict("dead_time", op, dead_time_s=1e-6, model="average_voltage", **LOOP)
    six6 = abs(2 * np.mean(six.waveform_pu * np.exp(-6j * six.angle_rad)))
    assert clamp.extras["order6_amplitude_pu"] == pytest.approx(six6, rel=0.05)


def test_clamping_adds_higher_orders_at_low_voltage():
    """250 rpm / 10 A, 2 µs: 2ε ≈ 0.96 V against a ≈ 1.4 V phase voltage — the dwell adds
    orders 12, 18, … and the pk-pk exceeds the six-step series' by more than 15 %."""
    op = OperatingPoint(speed_rpm=250, current_a=10.0)
    clamp = predict("dead_time", op, dead_time_s=2e-6, model="current_clamping", **LOOP)
    six = predict("dead_time", op, dead_time_s=2e-6, model="average_voltage", **LOOP)
    assert clamp.pk_pk_pu > 1.15 * six.pk_pk_pu


def test_reverse_rotation_mirrors_the_waveform_and_transducer_lags_in_time():
    forward = predict("dead_time", OperatingPoint(speed_rpm=500, current_a=10.0),
                      dead_time_s=2e-6, model="current_clamping", **LOOP)
    reverse = predict("dead_time", OperatingPoint(speed_rpm=-500, current_a=10.0),
                      dead_time_s=2e-6, model="current_clamping", **LOOP)
    assert reverse.extras["order6_amplitude_pu"] == pytest.approx(
        forward.extras["order6_amplitude_pu"], rel=1e-6)
    assert reverse.extras["order6_phase_rad"] == pytest.approx(
        -forward.extras["order6_phase_rad"], abs=1e-6)
    lagged = predict("dead_time", OperatingPoint(speed_rpm=500, current_a=10.0),
                     dead_time_s=2e-6, model="current_clamping", transducer_bandwidth_hz=1000.0,
                     **LOOP)
    # order 6 at 500 rpm, 2 pole pairs: 100 Hz; first order 1 kHz: −atan(0.1)
    assert lagged.extras["order6_phase_rad"] - forward.extras["order6_phase_rad"] == \
        pytest.approx(-math.atan(0.1), abs=1e-9)
    assert lagged.extras["order6_amplitude_pu"] == pytest.approx(
        forward.extras["order6_amplitude_pu"] / math.sqrt(1.01), rel=1e-9)
