"""The simulated drive's air-gap torque ripple at one operating point (for model-vs-twin checks).

The twin's electromagnetic torque over whole electrical revolutions is synchronously averaged
in the order domain — only whole electrical orders 1..``max_order`` are kept, as the analysis
does (which also drops the PWM-switching ripple and whatever does not repeat every revolution) —
before pk-pk. The twin's own PWM counter default (2000 counts) and
floating-point firmware stay unless the injection changes them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hil.sim import DriveTwin

SAMPLE_RATE_HZ = 200_000.0


@dataclass(frozen=True)
class TwinRipple:
    pk_pk_pu: float          # of the synchronous average, per unit of its mean
    revolutions: int
    mean_torque_nm: float
    order_amplitudes_pu: np.ndarray  # index k: amplitude of electrical order k, per unit of mean


def twin_ripple(injection: dict, op, *, max_order: int = 64, revolutions: int | None = None,
                seed: int = 1) -> TwinRipple:
    """Run the twin at ``op`` with ``injection`` and measure the order-domain ripple."""
    elec_period_s = 60.0 / (abs(op.speed_rpm) * op.motor.pole_pairs)
    duration_s = (revolutions + 0.05) * elec_period_s if revolutions else max(0.12,
                                                                              1.05 * elec_period_s)
    twin = DriveTwin(seed=seed)
    twin.set_injection(current_angle_rad=op.current_angle_rad, **injection)
    twin.speed_rpm, twin.current_command_a = op.speed_rpm, op.current_a
    twin.enable()
    twin.advance(0.03, SAMPLE_RATE_HZ)
    channels = twin.advance(duration_s, SAMPLE_RATE_HZ)
    theta = channels["rotor_angle_mech_rad"] * op.motor.pole_pairs
    whole = int(abs(theta[-1] - theta[0]) // (2 * math.pi))
    torque = channels["torque_em_nm"][abs(theta - theta[0]) < whole * 2 * math.pi]
    spectrum = np.fft.rfft(torque)
    bins = np.arange(spectrum.size)
    spectrum[(bins / whole > max_order) | (bins % whole != 0)] = 0  # whole orders 0..max_order
    smooth = np.fft.irfft(spectrum, torque.size)
    mean = float(np.mean(smooth))
    amplitudes = 2 * np.abs(spectrum[::whole][:max_order + 1]) / torque.size / mean
    return TwinRipple(float(np.ptp(smooth) / mean), whole, mean, amplitudes)
