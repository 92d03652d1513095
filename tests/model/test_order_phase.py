"""The predicted order phases (issue 21 item 4): the phasors of eqs 19 and 25 are the models'
own waveforms, name the sensor and the sign, and the bench chain moves them the right way."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hil.model import OperatingPoint, dc_offset, gain_mismatch
from hil.model.order_phase import chain_phase, transducer_phase_rad, wrap_rad

THETA = np.linspace(0.0, 2 * math.pi, 4096, endpoint=False)


def fourier(waveform: np.ndarray, order: int) -> complex:
    return complex(2.0 * np.mean(waveform * np.exp(-1j * order * THETA)))


@pytest.mark.parametrize("a, b, phi", [(0.01, 0.0, 0.0), (0.0, 0.02, 0.3), (-0.02, 0.01, -0.4)])
def test_dc_offset_phasor_is_the_waveform_of_eq_19(a, b, phi):
    assert dc_offset.order1_phasor(a, b, phi) == pytest.approx(
        fourier(dc_offset.ripple_pu(THETA, a, b, phi), 1), abs=1e-12)


@pytest.mark.parametrize("ga, gb, phi", [(0.01, -0.01, 0.0), (0.02, 0.0, 0.3), (-0.05, 0.1, -0.4)])
def test_gain_phasor_is_the_waveform_of_eq_25(ga, gb, phi):
    op = OperatingPoint(speed_rpm=500.0, current_a=20.0, current_angle_rad=phi)
    prediction = gain_mismatch.predict_gain_mismatch(op, ia_gain_error_pu=ga, ib_gain_error_pu=gb)
    wave = np.interp(THETA, prediction.angle_rad, prediction.waveform_pu, period=2 * math.pi)
    assert gain_mismatch.order2_phasor(ga, gb, phi) == pytest.approx(fourier(wave, 2), abs=1e-6)
    assert prediction.extras["order_phase_rad"] == pytest.approx(
        float(np.angle(fourier(wave, 2))), abs=1e-4)


def test_the_order_1_phase_names_the_sensor_and_the_sign():
    phase = lambda a, b: float(np.angle(dc_offset.order1_phasor(a, b)))  # noqa: E731
    assert phase(0.01, 0.0) == pytest.approx(math.pi / 3)
    assert phase(-0.01, 0.0) == pytest.approx(-2 * math.pi / 3)
    assert phase(0.0, 0.01) == pytest.approx(0.0, abs=1e-12)
    assert abs(phase(0.0, -0.01)) == pytest.approx(math.pi)
    # the magnitude cannot tell these apart
    assert abs(dc_offset.order1_phasor(0.01, 0)) == pytest.approx(
        abs(dc_offset.order1_phasor(0, 0.01)))


def test_the_order_2_phase_gives_the_sign_of_ka_minus_kb():
    plus = gain_mismatch.order2_phasor(0.01, -0.01, 0.2)
    minus = gain_mismatch.order2_phasor(-0.01, 0.01, 0.2)
    assert abs(plus) == pytest.approx(abs(minus), rel=1e-2)   # the mean moves a little with phi
    assert abs(wrap_rad(float(np.angle(plus)) - float(np.angle(minus)))) == pytest.approx(
        math.pi, abs=1e-9)
    # a current angle moves it: the phase is -phi - 7pi/6 for k1 > k2 (sensor a reads low)
    assert float(np.angle(minus)) == pytest.approx(wrap_rad(-0.2 - 7 * math.pi / 6))


def test_the_chain_correction_follows_the_direction_of_rotation():
    kwargs = dict(transducer_bandwidth_hz=1000.0, loop_bandwidth_hz=1600.0, loop_delay_s=75e-6,
                  angle_counts_per_rev=7200)
    forward = chain_phase(2, 500.0, 2, **kwargs)
    reverse = chain_phase(2, -500.0, 2, **kwargs)
    assert forward.frequency_hz == reverse.frequency_hz == pytest.approx(2 * 500 / 60 * 2)
    assert forward.correction_rad == pytest.approx(-math.atan(forward.frequency_hz / 1000.0))
    assert reverse.correction_rad == -forward.correction_rad
    assert forward.model_u_rad == pytest.approx(
        math.atan(33.33 / 1000) + math.atan(33.33 / 1600) + 2 * math.pi * 33.33 * 75e-6
        + math.pi * 2 / 7200, rel=1e-3)
    assert transducer_phase_rad(100.0, None) == 0.0
    assert wrap_rad(math.pi) == pytest.approx(math.pi)
    assert wrap_rad(-math.pi) == pytest.approx(math.pi)
