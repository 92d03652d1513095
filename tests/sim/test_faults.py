"""Each injected controller limitation, alone, gives the torque ripple physics predicts.

References are hand-derived from the torque sum T = Σ e_x·i_x/ω_m (eq 7) with the currents an
ideal regulator would produce from the *sensed* signals (eqs 15-17, 21-23, and the encoder
staircase of eq 4), evaluated at the simulated rotor angles. The simulation gets its currents
from the PWM inverter, the PI loop with its 1.5-period delay and the 12-bit ADC instead, so the
comparison is of the harmonic the fault creates, with tolerances that say what differs.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from hil.motor import TABLE_I
from hil.sim import DriveConfig, DynoModel, Injection, simulate
from sim_spectra import (TORQUE_PER_A, amplitude_at, commanded_currents, dominant_order,
                         ideal_torque, orders, run)

REVS = 4


def _theta_e(result):
    return result.meta["pole_pairs"] * result["rotor_angle_mech_rad"]


def test_baseline_ripple_is_small_and_has_no_low_order():
    # no fault: the valley-sampled torque carries only the PWM/ADC residue (< 0.1 % per order
    # below the 6th; the ADC's 0.05 A LSB alone is 0.5 % of 10 A)
    result = run()
    torque = result["torque_em_nm"]
    freq, amp = orders(torque, REVS)
    assert np.ptp(torque) / torque.mean() < 0.02
    assert amp[(freq >= 0.5) & (freq <= 6.5)].max() < 1e-3
    assert torque.mean() == pytest.approx(10.0 * TORQUE_PER_A, rel=0.005)


@pytest.mark.parametrize("ia_offset_a, ib_offset_a", [(0.2, 0.0), (0.2, 0.2), (-0.3, 0.1)])
def test_dc_offset_gives_order_one_of_the_torque_sum(ia_offset_a, ib_offset_a):
    # eqs 15-18: regulating the sensed current means actual = command − offset. 5 %: the loop
    # gain at 10 Hz is finite (fc = 1.6 kHz) and the ADC quantises the 0.2 A offset (LSB 0.05 A).
    result = run(ia_offset_a=ia_offset_a, ib_offset_a=ib_offset_a)
    theta = _theta_e(result)
    ca, cb, _ = commanded_currents(theta, 10.0)
    ia, ib = ca - ia_offset_a, cb - ib_offset_a
    reference = ideal_torque(theta, ia, ib, -ia - ib)
    simulated = result["torque_em_nm"]
    assert dominant_order(simulated, REVS) == 1.0
    assert amplitude_at(simulated, REVS, 1) == pytest.approx(
        amplitude_at(reference, REVS, 1), rel=0.05)


@pytest.mark.parametrize("k1, k2", [(0.02, -0.02), (0.05, 0.0)])
def test_gain_mismatch_gives_order_two_of_the_torque_sum(k1, k2):
    # eqs 21-24: sensed = (1 + k)·actual, so actual = command/(1 + k). 5 % as above.
    result = run(ia_gain_error_pu=k1, ib_gain_error_pu=k2)
    theta = _theta_e(result)
    ca, cb, _ = commanded_currents(theta, 10.0)
    ia, ib = ca / (1 + k1), cb / (1 + k2)
    reference = ideal_torque(theta, ia, ib, -ia - ib)
    simulated = result["torque_em_nm"]
    assert dominant_order(simulated, REVS) == 2.0
    assert amplitude_at(simulated, REVS, 2) == pytest.approx(
        amplitude_at(reference, REVS, 2), rel=0.05)


@pytest.mark.parametrize("current_angle_rad", [0.0, 0.5])
def test_encoder_decimation_gives_the_count_frequency(current_angle_rad):
    # eq 4/7: the current follows the firmware's staircase angle θ_d (10° electrical with
    # decimation 100). At 30 rpm the count frequency (360 Hz) is well inside the loop bandwidth,
    # so the harmonics of the staircase match within 3 %; the pk-pk does not (the regulator
    # overshoots at each step), which is why the harmonic is compared.
    revs = 2
    result = run(speed_rpm=30.0, revs=revs, encoder_decimation=100,
                 current_angle_rad=current_angle_rad)
    theta = _theta_e(result)
    used = np.floor(result["encoder_counts"] / 100) * 100
    theta_d = 2 * math.pi * ((used * 2) % 7200) / 7200
    reference = ideal_torque(theta, *commanded_currents(theta_d, 10.0, current_angle_rad))
    simulated = result["torque_em_nm"]
    assert dominant_order(simulated, revs) == 36.0
    for order in (36, 72):
        assert amplitude_at(simulated, revs, order) == pytest.approx(
            amplitude_at(reference, revs, order), rel=0.03)


def test_hall_mode_gives_order_six_larger_than_fine_encoder():
    hall = run(speed_rpm=30.0, revs=2, hall_mode=True)["torque_em_nm"]
    fine = run(speed_rpm=30.0, revs=2, encoder_decimation=100)["torque_em_nm"]
    assert dominant_order(hall, 2) == 6.0
    assert np.ptp(hall) / hall.mean() > 5 * np.ptp(fine) / fine.mean()


def test_dead_time_gives_order_six_growing_with_dead_time():
    # the lost volt-seconds switch sign with each phase current: six steps per electrical rev
    small = run(dead_time_s=0.5e-6)["torque_em_nm"]
    large = run(dead_time_s=2e-6)["torque_em_nm"]
    assert dominant_order(small, REVS) == 6.0
    assert dominant_order(large, REVS) == 6.0
    assert amplitude_at(large, REVS, 6) > 2.0 * amplitude_at(small, REVS, 6)


def test_word_length_ripple_shrinks_with_bits_and_stays_under_the_paper_bound():
    # eq 14 bounds the per-unit current error by 5/2^(n-1) of full scale (torque 10/2^(n-1)).
    # Truncation is biased, so much of the error is an offset-like order-1 term (not the paper's
    # zero-mean noise); the pk-pk still stays below the bound, per unit of full-scale torque.
    full_scale_torque = 100.0 * TORQUE_PER_A
    ripples = {}
    for bits in (8, 10, 12):
        torque = run(current_a=50.0, word_length_bits=bits)["torque_em_nm"]
        ripples[bits] = np.ptp(torque) / full_scale_torque
        assert ripples[bits] < 10.0 / 2 ** (bits - 1)
    assert ripples[8] > ripples[10] > ripples[12]
    floating = run(current_a=50.0)["torque_em_nm"]
    wide = run(current_a=50.0, word_length_bits=24)["torque_em_nm"]
    # 24 bits: at most a count of PWM difference now and then, not a ripple of its own
    assert np.abs(wide - floating).max() < 0.005 * floating.mean()


def test_pwm_resolution_ripple_grows_as_counts_drop():
    ripple = {}
    for counts in (2000, 100, 20):
        torque = run(pwm_period_counts=counts)["torque_em_nm"]
        ripple[counts] = np.ptp(torque) / torque.mean()
    assert ripple[20] > 2 * ripple[100] > 2 * ripple[2000]


def test_zero_speed_encoder_experiment_follows_the_staircase():
    # the paper's Fig. 3 set-up: the dyno steps the rotor slowly (1° electrical every 5 ms) and
    # the torque is read at rest; at standstill the loop settles fully, so the torque at the end
    # of each dwell (read at a PWM valley, free of the switching ripple) is (3/2)·ψ·I·cos(γ + φ)
    # (eq 7) to within the ADC's resolution (0.05 A of 10 A: 0.5 %)
    phi = math.radians(10.0)
    step = 2 * math.pi / 7200 * 5                       # 5 counts: 1° electrical
    dyno = DynoModel(mode="stepping", step_mech_rad=step, dwell_s=0.005)
    config = DriveConfig(dyno=dyno, speed_rpm=6.0, current_command_a=10.0,
                         injection=Injection(encoder_decimation=100, current_angle_rad=phi))
    move_s = step / (6.0 * 2 * math.pi / 60)
    cycle = 0.005 + move_s
    result = simulate(config, 24 * cycle, 20_000)
    ends = np.round((np.arange(24) * cycle + 0.005 - 1e-4) * 20_000).astype(int)   # dwell ends
    theta = 2 * result["rotor_angle_mech_rad"][ends]
    used = np.floor(result["encoder_counts"][ends] / 100) * 100
    gamma = theta - 2 * math.pi * ((used * 2) % 7200) / 7200
    expected = 1.5 * TABLE_I.emf_peak_v_s_per_rad * 10.0 * np.cos(gamma + phi)
    np.testing.assert_allclose(result["torque_em_nm"][ends], expected, rtol=0.005)
    assert np.ptp(gamma) > math.radians(8)              # the dwells span a whole count step
