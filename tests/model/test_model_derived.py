"""Two-sided derived expectations for the bound-only sources (word length, PWM resolution) and
the sweep sensitivities: checked against fixed-point arithmetic and the simulated drive, and
shown to exclude a drive that ignores the injection (issue 13, item 1)."""

import math

import numpy as np
import pytest

from hil.errors import InputError
from hil.model import OperatingPoint, predict
from hil.model.sensitivity import sensitivity
from hil.model.word_length import BIAS_TERM_REL_UNCERTAINTY
from model_torque_sum import balanced
from twin_ripple import twin_ripple

LOOP = {"current_loop_bandwidth_hz": 1600.0, "current_loop_delay_s": 75e-6}  # the twin's loop
PLAN_POINT = OperatingPoint(speed_rpm=500, current_a=20.0)  # the simulated bench's point


def trunc(x, lsb):
    """Two's-complement truncation toward −∞ to a grid of ``lsb``."""
    return np.floor(np.asarray(x) / lsb) * lsb


def computed_iq_error_a(theta, current_a, bits, adc_bits=12, full_scale_a=100.0):
    """I_q as an n-bit firmware computes it from ideal currents, minus the true I_q, amperes.

    Independent of the model: ADC (mid-tread) → word, i_c = −(i_a + i_b), sin/cos table entries,
    the other phases' sines by identities (each product truncated), Park products, 2/3, result.
    """
    lsb = 2.0 ** (1 - bits)
    half = 2.0 ** (adc_bits - 1)
    currents = balanced(theta, current_a)
    codes = np.floor((currents[:2] / full_scale_a + 1.0) * half + 0.5)
    i_a, i_b = trunc((codes - half) / half, lsb)
    i_c = trunc(-i_a - i_b, lsb)
    s_a, c_a = trunc(np.sin(theta), lsb), trunc(np.cos(theta), lsb)
    root3_2, two_thirds = trunc(math.sqrt(3) / 2, lsb), trunc(2 / 3, lsb)
    s_b = trunc(-trunc(0.5 * s_a, lsb) - trunc(root3_2 * c_a, lsb), lsb)
    s_c = trunc(-trunc(0.5 * s_a, lsb) + trunc(root3_2 * c_a, lsb), lsb)
    products = trunc(i_a * s_a, lsb) + trunc(i_b * s_b, lsb) + trunc(i_c * s_c, lsb)
    return trunc(two_thirds * products, lsb) * full_scale_a - current_a


@pytest.mark.parametrize("bits", [8, 10])
@pytest.mark.parametrize("current_a", [10.0, 40.0])
def test_word_length_order1_term_matches_fixed_point_arithmetic(bits, current_a):
    op = OperatingPoint(speed_rpm=500, current_a=current_a)
    pred = predict("word_length", op, word_length_bits=bits, model="derived")
    theta = np.linspace(0, 2 * math.pi, 40000, endpoint=False)
    error = computed_iq_error_a(theta, current_a, bits)
    order1 = 2 * abs(np.fft.rfft(error)[1]) / theta.size
    assert pred.extras["order1_pk_pk_pu"] == pytest.approx(2 * order1 / current_a,
                                                           rel=BIAS_TERM_REL_UNCERTAINTY)
    spectrum = np.fft.rfft(error)
    spectrum[:3] = 0  # mean, order 1 and the order-2 term of the truncated √3/2
    fluctuation = np.fft.irfft(spectrum, theta.size)
    assert np.std(fluctuation) == pytest.approx(pred.extras["truncation_noise_std_a"], rel=0.25)


@pytest.mark.parametrize("bits,speed_rpm,current_a", [
    (8, 500, 20.0), (10, 500, 20.0), (12, 500, 20.0), (8, 1000, 10.0), (10, 1000, 40.0)])
def test_word_length_derived_range_holds_the_twin(bits, speed_rpm, current_a):
    op = OperatingPoint(speed_rpm=speed_rpm, current_a=current_a)
    pred = predict("word_length", op, word_length_bits=bits, model="derived")
    twin = twin_ripple({"word_length_bits": bits}, op, revolutions=12)
    low, high = pred.expected_range_pu
    assert low <= twin.pk_pk_pu <= high
    assert twin.pk_pk_pu < pred.extras["paper_pk_pk_pu"]  # the paper's bound stays a bound
    if bits < 12:  # the sensor-bias term dominates: order 1, within its ±20 %
        assert pred.order == 1.0 and np.argmax(twin.order_amplitudes_pu[1:]) == 0
        assert 2 * twin.order_amplitudes_pu[1] == pytest.approx(pred.extras["order1_pk_pk_pu"],
                                                                rel=0.2)


def test_word_length_derived_excludes_a_drive_that_ignores_the_injection():
    ignoring = twin_ripple({}, PLAN_POINT, revolutions=12).pk_pk_pu
    for bits in (8, 10):
        low, _ = predict("word_length", PLAN_POINT, word_length_bits=bits,
                         model="derived").expected_range_pu
        assert ignoring < low / 4
    # ... and a drive two bits off: 10 bits measured where 8 were injected, and vice versa
    eight, ten = (twin_ripple({"word_length_bits": b}, PLAN_POINT, revolutions=12).pk_pk_pu
                  for b in (8, 10))
    assert ten < predict("word_length", PLAN_POINT, word_length_bits=8,
                         model="derived").expected_range_pu[0]
    assert eight > predict("word_length", PLAN_POINT, word_length_bits=10,
                           model="derived").expected_range_pu[1]


def test_word_length_derived_sensor_term_vanishes_at_the_adc_resolution():
    pred = predict("word_length", PLAN_POINT, word_length_bits=12, model="derived")
    assert pred.extras["sensor_bias_a"] == 0.0
    finer_adc = predict("word_length", PLAN_POINT, word_length_bits=12, adc_bits=16,
                        model="derived")
    assert finer_adc.extras["sensor_bias_a"] == pytest.approx(0.5 * (2 ** -11 - 2 ** -15) * 100)
    tables = predict("word_length", PLAN_POINT, word_length_bits=12, trig_values="tables",
                     model="derived")
    assert tables.extras["order1_pk_pk_pu"] == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("counts,revolutions", [(32, 2), (32, 8), (64, 8), (128, 8),
                                                (128, 24)])
def test_pwm_resolution_derived_range_holds_the_twin(counts, revolutions):
    twin = twin_ripple({"pwm_period_counts": counts}, PLAN_POINT, revolutions=revolutions)
    pred = predict("pwm_resolution", PLAN_POINT, pwm_period_counts=counts, model="derived",
                   revolutions_averaged=twin.revolutions, **LOOP)
    low, high = pred.expected_range_pu
    assert low <= twin.pk_pk_pu <= high
    assert pred.extras["offset_trials_min_pu"] <= pred.extras["single_revolution_pk_pk_pu"] \
        <= pred.extras["offset_trials_max_pu"]
    assert pred.pk_pk_pu == pytest.approx(pred.extras["single_revolution_pk_pk_pu"]
                                          / math.sqrt(twin.revolutions))


def test_pwm_resolution_derived_excludes_a_drive_that_ignores_the_injection():
    twin = twin_ripple({}, PLAN_POINT, revolutions=8)  # default counter, 2000
    for counts in (32, 64):  # at 128 counts the lower limit meets the drive's own floor
        low, _ = predict("pwm_resolution", PLAN_POINT, pwm_period_counts=counts,
                         model="derived", revolutions_averaged=twin.revolutions,
                         **LOOP).expected_range_pu
        assert twin.pk_pk_pu < low


def test_pwm_resolution_derived_refuses_the_voltage_limit():
    limit_rpm = OperatingPoint(0, 40.0).voltage_limited_speed_rpm()
    with pytest.raises(InputError, match="V_dc/√3"):  # the point itself: beyond SVPWM's range
        OperatingPoint(speed_rpm=1.05 * limit_rpm, current_a=40.0)
    within_svpwm = OperatingPoint(speed_rpm=0.95 * limit_rpm, current_a=40.0)  # > V_dc/2
    with pytest.raises(InputError, match="sine linear range"):
        predict("pwm_resolution", within_svpwm, pwm_period_counts=32, model="derived",
                modulation="sine", **LOOP)
    with pytest.raises(InputError, match="current_loop_bandwidth_hz"):
        predict("pwm_resolution", PLAN_POINT, pwm_period_counts=32, model="derived")


def test_sensitivity_slopes_follow_the_twin_across_the_sweeps():
    words = sensitivity("word_length", PLAN_POINT, "word_length_bits", [8, 10, 12],
                        model="derived")
    assert words.step == "bit" and len(words.slopes_pu) == 2
    twin = [twin_ripple({"word_length_bits": b}, PLAN_POINT, revolutions=12).pk_pk_pu
            for b in (8, 10, 12)]
    measured_slopes = [(twin[1] - twin[0]) / 2, (twin[2] - twin[1]) / 2]
    for model_slope, twin_slope in zip(words.slopes_pu, measured_slopes):
        assert model_slope == pytest.approx(twin_slope, rel=0.3)
    counters = sensitivity("pwm_resolution", PLAN_POINT, "pwm_period_counts", [32, 64],
                           model="derived", revolutions_averaged=8, **LOOP)
    assert counters.step == "halving of the counter" and counters.steps == [-5.0, -6.0]
    twin32, twin64 = (twin_ripple({"pwm_period_counts": c}, PLAN_POINT, revolutions=8).pk_pk_pu
                      for c in (32, 64))
    # halving the counter (64 → 32) raises the ripple: the slope per halving is positive
    assert counters.slopes_pu[0] > 0
    assert counters.slopes_pu[0] == pytest.approx(twin32 - twin64, rel=0.35)


def test_sensitivity_of_exact_forms_and_bad_input():
    offsets = sensitivity("dc_offset", PLAN_POINT, "offset_a_pu", [0.01, 0.02, 0.03])
    assert offsets.step == "% of I"
    assert offsets.slopes_pu == pytest.approx([4 / math.sqrt(3) / 100] * 2)  # eq 19, one sensor
    dead = sensitivity("dead_time", PLAN_POINT, "dead_time_s", [1e-6, 2e-6],
                       model="average_voltage", **LOOP)
    assert dead.step == "µs" and dead.slopes_pu[0] > 0
    with pytest.raises(InputError, match="allowed: word_length_bits"):
        sensitivity("word_length", PLAN_POINT, "dead_time_s", [1e-6, 2e-6])
    with pytest.raises(InputError, match="at least 2"):
        sensitivity("word_length", PLAN_POINT, "word_length_bits", [8])
    with pytest.raises(InputError, match="differ"):
        sensitivity("word_length", PLAN_POINT, "word_length_bits", [8, 8])
