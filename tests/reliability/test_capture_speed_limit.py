"""The captured-speed limit check reads the speed of a quantised encoder angle over a window: at
~190 kS/s a 2475 rpm rotor moves 1-2 counts per sample, and the sample-to-sample difference read
up to 3329 rpm (a false trip of a 3000 rpm limit that failed correct drives in the validity
study); a real overspeed still trips."""

import numpy as np

from hil.bench import windowed_speed_rpm

COUNTS_PER_REV = 7200


def quantised_angle(speed_rpm: float, rate_hz: float, duration_s: float = 0.02):
    time_s = np.arange(int(duration_s * rate_hz)) / rate_hz
    exact = speed_rpm / 60.0 * 2 * np.pi * time_s
    step = 2 * np.pi / COUNTS_PER_REV
    return time_s, np.floor(exact / step) * step


def test_a_quantised_angle_sampled_fast_reads_its_speed():
    time_s, angle = quantised_angle(2475.0, 190_000.0)
    naive = np.diff(angle) / np.diff(time_s) * 60 / (2 * np.pi)
    assert naive.max() > 3000.0                        # what tripped the limit
    speed = windowed_speed_rpm(time_s, angle)
    assert np.max(np.abs(speed - 2475.0)) < 10.0       # one count over 1 ms ≈ 8 rpm


def test_a_real_overspeed_is_still_seen():
    time_s, angle = quantised_angle(3100.0, 190_000.0)
    assert windowed_speed_rpm(time_s, angle).max() > 3000.0
    time_s, angle = quantised_angle(-3100.0, 8_000.0)   # slow DAQ, reverse
    assert np.abs(windowed_speed_rpm(time_s, angle)).max() > 3000.0
