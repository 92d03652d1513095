"""Seeded synthetic captures whose analysis results are frozen in ``reference_results.npz``.

The fixture guards the analysis chain's speed work (issue 17 item 5): a faster path must give the
results of the path it replaced to 1e-12 relative. The cases walk every branch of the chain:
wrapped/unwrapped angle, both directions, encoder staircases (de-quantisation) and dither
(de-jittering), an angle integrated from speed, both pk-pk methods, one revolution only (no type
A), a varying speed (the interpolation response) and the within-PWM-period switching analysis,
which shares the angle and resampling steps.

Regenerate (only when a result is *meant* to change, and say why in the commit):
``.venv/bin/python tests/analysis/reference_cases.py`` run from the repository root.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from analysis_synthetic import TWO_PI, ripple, speed_profile_angle  # noqa: E402
from hil.analysis import InstrumentUncertainty, analyze_capture, analyze_torque  # noqa: E402
from hil.analysis.switching import analyze_switching  # noqa: E402
from hil.capture import Capture  # noqa: E402
from hil.motor import TABLE_I  # noqa: E402

REFERENCE_PATH = Path(__file__).resolve().parent / "reference_results.npz"
INSTRUMENTS = InstrumentUncertainty(transducer_accuracy_class_pct=0.1,
                                    transducer_full_scale_nm=5.0, daq_lsb_nm=1e-3)
SCALAR_FIELDS = ("mean_torque_nm", "pk_pk_nm", "pk_pk_pu", "rms_ac_nm", "revolutions",
                 "samples_per_rev", "direction", "dominant_order")
ARRAY_FIELDS = ("amplitude_nm", "phase_rad", "amplitude_u_nm", "angle_grid_rad",
                "sync_average_nm", "revolution_matrix_nm")
BUDGET_FIELDS = ("combined_standard_pu", "expanded_pu", "noise_bias_pu")


def _noisy(rng_seed: int, values: np.ndarray, sigma_nm: float) -> np.ndarray:
    return values + np.random.default_rng(rng_seed).normal(0.0, sigma_nm, values.size)


def bench_like():
    """The benchmark's content at 50 k samples: ±5 % speed wobble, orders 6 and 36, noise."""
    time_s = np.arange(50_000) / 100_000.0
    angle = speed_profile_angle(time_s, electrical_hz=66.7, variation=0.05, modulation_hz=1.3)
    torque = _noisy(0, ripple(angle, 1.0, {6: (0.02, 0.7), 36: (0.005, 0.0)}), 0.01)
    return analyze_torque(time_s, torque, angle, max_order=64, named_order=6,
                          instruments=INSTRUMENTS)


def wrapped_backwards():
    """Negative speed, wrapped mechanical angle, 2 pole pairs, negative mean torque."""
    time_s = np.arange(30_000) / 20_000.0
    angle = -speed_profile_angle(time_s, electrical_hz=30.0, variation=0.05)
    torque = _noisy(1, ripple(angle, -1.2, {1: (0.03, 0.9), 6: (0.01, -0.3)}), 0.004)
    capture = Capture({"time_s": time_s, "torque_nm": torque,
                       "rotor_angle_mech_rad": np.mod(angle / 2, TWO_PI)}, meta={"pole_pairs": 2})
    return analyze_capture(capture, max_order=16, named_order=6, instruments=INSTRUMENTS)


def encoder_creeping():
    """A rotor creeping and pausing, angle from a 7200-count encoder (runs of equal counts)."""
    time_s = np.arange(60_000) / 10_000.0
    speed = 0.6 * (1.0 + np.sin(TWO_PI * 2.0 * time_s)) ** 2 + 2.0
    true_angle = np.concatenate(([0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) / 10_000.0)))
    torque = _noisy(2, ripple(true_angle, 0.8, {6: (0.02, 0.7), 36: (0.01, -1.0)}), 0.002)
    counts = np.floor(true_angle / 2 / TWO_PI * 7200)
    capture = Capture({"time_s": time_s, "torque_nm": torque, "encoder_counts": counts},
                      meta={"pole_pairs": 2, "encoder_counts_per_rev": 7200})
    return analyze_capture(capture, max_order=48, named_order=36)


def encoder_dither_bins():
    """Slow rotor, encoder staircase dithering back by a count now and then, bins pk-pk."""
    time_s = np.arange(40_000) / 20_000.0
    true_angle = TWO_PI * 1.7 * time_s * (1 + 0.05 * np.sin(TWO_PI * 0.4 * time_s))
    counts = np.floor(true_angle / 2 / TWO_PI * 7200)
    dither = np.random.default_rng(4).random(time_s.size) < 0.01
    counts = counts - dither
    torque = _noisy(5, np.cos(np.mod(true_angle, np.deg2rad(10.0))), 0.003)
    capture = Capture({"time_s": time_s, "torque_nm": torque, "encoder_counts": counts},
                      meta={"pole_pairs": 2, "encoder_counts_per_rev": 7200})
    return analyze_capture(capture, max_order=360, named_order=36, pk_pk_method="bins",
                           instruments=INSTRUMENTS)


def from_speed_channel():
    """Angle integrated from a speed channel (rpm), 2 pole pairs."""
    time_s = np.arange(25_000) / 20_000.0
    angle = speed_profile_angle(time_s, electrical_hz=40.0, variation=0.05, start_rad=0.0)
    speed_rpm = np.gradient(angle, time_s) / 2 / TWO_PI * 60.0
    torque = _noisy(6, ripple(angle, 1.1, {6: (0.01, 0.2), 12: (0.004, 1.0)}), 0.003)
    capture = Capture({"time_s": time_s, "torque_nm": torque, "speed_rpm": speed_rpm},
                      meta={"pole_pairs": 2})
    return analyze_capture(capture, max_order=24, named_order=6, rated_torque_nm=2.0)


def one_revolution():
    """1.4 revolutions: one whole revolution, no type-A estimate (NaN)."""
    time_s = np.arange(700) / 20_000.0
    angle = 0.3 + TWO_PI * 40.0 * time_s
    torque = _noisy(7, ripple(angle, 1.0, {3: (0.02, 0.1)}), 0.001)
    return analyze_torque(time_s, torque, angle, max_order=8, instruments=INSTRUMENTS)


def switching():
    """Within-PWM-period ripple: i_q carries a 20 kHz triangle whose pk-pk follows order 6."""
    electrical_hz = 500.0 / 60.0 * TABLE_I.pole_pairs
    time_s = np.arange(int(4.25 / electrical_hz * 182_000.0)) / 182_000.0
    angle = 0.4 + TWO_PI * electrical_hz * time_s
    envelope = 0.05 * (1.0 + 0.2 * np.cos(6 * angle + 0.7))
    triangle = 2.0 * np.abs(2.0 * np.mod(time_s * 20_000.0 + 0.13, 1.0) - 1.0) - 1.0
    iq = _noisy(8, 1.0 + 0.5 * envelope * triangle, 0.001) / (1.5 * TABLE_I.emf_peak_v_s_per_rad)
    capture = Capture({"time_s": time_s, "ia_a": iq * np.sin(angle),
                       "ib_a": iq * np.sin(angle - 2.0 * math.pi / 3.0),
                       "rotor_angle_mech_rad": angle / TABLE_I.pole_pairs},
                      units={}, meta={"pole_pairs": TABLE_I.pole_pairs})
    return analyze_switching(capture, pwm_frequency_hz=20_000.0, motor=TABLE_I, max_order=24)


CASES = {case.__name__: case for case in (bench_like, wrapped_backwards, encoder_creeping,
                                          encoder_dither_bins, from_speed_channel,
                                          one_revolution, switching)}


def figures(result) -> dict[str, np.ndarray]:
    """The compared figures of one RippleResult, flat name → array."""
    data = {name: np.asarray(getattr(result, name), dtype=np.float64)
            for name in SCALAR_FIELDS + ARRAY_FIELDS}
    data.update({name: np.asarray(getattr(result.uncertainty, name), dtype=np.float64)
                 for name in BUDGET_FIELDS})
    return data


def main() -> None:
    stored = {f"{case}/{name}": values for case, build in CASES.items()
              for name, values in figures(build()).items()}
    np.savez_compressed(REFERENCE_PATH, **stored)
    print(f"wrote {len(stored)} arrays of {len(CASES)} cases to {REFERENCE_PATH}")


if __name__ == "__main__":
    main()
