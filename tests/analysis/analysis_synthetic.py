"""Synthetic captures of known content for the analysis tests."""

from __future__ import annotations

import numpy as np

TWO_PI = 2.0 * np.pi


def speed_profile_angle(time_s: np.ndarray, electrical_hz: float, variation: float = 0.0,
                        modulation_hz: float = 0.7, start_rad: float = 0.3) -> np.ndarray:
    """Electrical angle of a rotor at ``electrical_hz`` whose speed varies by ±``variation``
    (per unit of the mean speed) sinusoidally at ``modulation_hz``."""
    omega = TWO_PI * electrical_hz
    wobble = omega * variation / (TWO_PI * modulation_hz)
    return start_rad + omega * time_s - wobble * np.cos(TWO_PI * modulation_hz * time_s) + wobble


def ripple(angle_rad: np.ndarray, mean_nm: float, orders: dict[int, tuple[float, float]]):
    """mean + Σ A cos(kθ + φ) for ``orders`` = {k: (A_nm, φ_rad)}."""
    torque = np.full_like(angle_rad, mean_nm)
    for order, (amplitude, phase) in orders.items():
        torque += amplitude * np.cos(order * angle_rad + phase)
    return torque
