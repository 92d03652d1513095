"""Small helpers for the twin's tests: order spectra over whole electrical revolutions and the
hand-derived torque of ideal currents (the physics references the tests compare against)."""

from __future__ import annotations

import math

import numpy as np

from hil.motor import TABLE_I
from hil.sim import DriveConfig, Injection, simulate

TORQUE_PER_A = TABLE_I.torque_constant_nm_per_a       # (3/2)·E/ω_m, N·m per peak ampere
PWM_HZ = 20000.0


def run(speed_rpm=300.0, current_a=10.0, revs=4, sample_rate_hz=PWM_HZ, settle_s=0.05,
        config=None, **knobs):
    """Simulate whole electrical revolutions after settling; sampled at the PWM valleys by
    default (sample rate = PWM rate, so the switching ripple is not aliased into the orders)."""
    if config is None:
        config = DriveConfig(injection=Injection(**knobs), current_command_a=current_a,
                             speed_rpm=speed_rpm)
    electrical_hz = TABLE_I.pole_pairs * abs(config.speed_rpm) / 60.0
    return simulate(config, revs / electrical_hz, sample_rate_hz, settle_s=settle_s)


def orders(signal: np.ndarray, revs: int) -> tuple[np.ndarray, np.ndarray]:
    """(electrical order, amplitude per unit of the mean) of a signal spanning ``revs`` revs."""
    spectrum = np.abs(np.fft.rfft(signal - signal.mean())) * 2.0 / len(signal)
    return np.arange(len(spectrum)) / revs, spectrum / abs(signal.mean())


def amplitude_at(signal, revs, order) -> float:
    freq, amp = orders(signal, revs)
    return float(amp[np.argmin(np.abs(freq - order))])


def dominant_order(signal, revs, minimum_order=0.5) -> float:
    freq, amp = orders(signal, revs)
    amp = np.where(freq >= minimum_order, amp, 0.0)
    return float(freq[np.argmax(amp)])


def ideal_torque(theta_e, ia, ib, ic):
    """T = Σ e_x·i_x/ω_m for the sinusoidal Table I EMF (eq 7 numerator), N·m."""
    psi = TABLE_I.emf_peak_v_s_per_rad
    return psi * (ia * np.sin(theta_e) + ib * np.sin(theta_e - 2 * math.pi / 3)
                  + ic * np.sin(theta_e + 2 * math.pi / 3))


def commanded_currents(theta_e, amplitude_a, current_angle_rad=0.0):
    """The sinusoids the firmware regulates its *sensed* currents to (eq 4)."""
    return tuple(amplitude_a * np.sin(theta_e - current_angle_rad - k * 2 * math.pi / 3)
                 for k in range(3))
