"""The direct numerical torque sum T = Σ e_x·i_x/ω_m (paper eq 7) the closed forms are checked with."""

from __future__ import annotations

import math

import numpy as np

from hil.motor import TABLE_I

#: Phase offsets: e_b = E·sin(θ − 2π/3), e_c = E·sin(θ + 2π/3) (paper eqs 1-3).
OFFSETS = np.array([0.0, 2 * math.pi / 3, -2 * math.pi / 3])


def balanced(theta, amplitude=1.0, lag_rad=0.0):
    """Three rows amplitude·sin(θ − lag − o_x)."""
    theta = np.asarray(theta, dtype=float)
    return amplitude * np.sin(theta[None, ...] - lag_rad - OFFSETS.reshape(3, *([1] * theta.ndim)))


def torque_nm(theta, currents_a, motor=TABLE_I):
    """Σ e_x·i_x/ω_m with e_x/ω_m = sqrt(2)·Ke·sin(θ − o_x): valid at any speed, even zero."""
    return motor.emf_peak_v_s_per_rad * np.sum(balanced(theta) * currents_a, axis=0)


def pk_pk_over_mean(torque):
    torque = np.asarray(torque)
    return float(np.ptp(torque) / np.mean(torque))
