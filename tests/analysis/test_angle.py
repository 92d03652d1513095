"""Travel angle: unwrap, orientation, encoder jitter and staircase de-quantisation."""

from __future__ import annotations

import numpy as np
import pytest

from hil.analysis.angle import TWO_PI, angle_from_speed, check_time, travel_angle
from hil.errors import InputError


def test_wrapped_angle_is_unwrapped_and_strictly_increasing_angle_kept():
    time_s = np.arange(1000) * 1e-3
    angle = 0.1 + 25.0 * time_s
    travel = travel_angle(time_s, np.mod(angle, TWO_PI))
    assert travel.direction == 1
    np.testing.assert_allclose(travel.travel_rad, angle, atol=1e-12)


def test_encoder_dither_is_flattened_not_refused():
    count_rad = TWO_PI / 3600
    counts = np.concatenate((np.tile([10, 11], 50), np.arange(11, 500)))
    time_s = np.arange(counts.size) * 1e-3
    travel = travel_angle(time_s, counts * count_rad)
    assert np.all(np.diff(travel.travel_rad) >= 0)
    assert travel.travel_rad[0] == pytest.approx(11 * count_rad)
    assert travel.travel_rad[-1] == pytest.approx(498 * count_rad)


def test_staircase_is_interpolated_between_run_mid_times():
    time_s = np.arange(40) * 1.0
    staircase = np.repeat(np.arange(10.0), 4)         # 4 samples per step, steps of 1 rad
    travel = travel_angle(time_s, staircase).travel_rad
    # interior runs are anchored at their mid-time: run k (samples 4k..4k+3) at t = 4k + 1.5
    # (the first and last runs are cut by the record and give no anchor: clamped there)
    assert travel[9] == pytest.approx(1.0 + (9 - 5.5) / 4)
    assert travel[21] == pytest.approx(4.0 + (21 - 17.5) / 4)
    assert travel[2] == travel[5] == pytest.approx(1.0)
    assert np.all(np.diff(travel[6:34]) > 0)


def test_backward_motion_and_standstill_are_refused():
    time_s = np.arange(100) * 1e-3
    with pytest.raises(InputError, match="runs backwards"):
        travel_angle(time_s, np.concatenate((np.linspace(0, 3, 50), np.linspace(2, 6, 50))))
    with pytest.raises(InputError, match="never advances"):
        travel_angle(time_s, np.zeros(100))


def test_time_checks_and_speed_integration():
    with pytest.raises(InputError, match="not strictly increasing"):
        check_time(np.array([0.0, 1.0, 1.0, 2.0]))
    with pytest.raises(InputError, match="non-finite"):
        check_time(np.array([0.0, np.nan, 2.0]))
    time_s = np.linspace(0.0, 1.0, 1001)
    angle = angle_from_speed(time_s, np.full(time_s.size, 60.0))   # 1 rev/s
    assert angle[-1] == pytest.approx(TWO_PI)
