"""The compiled passes of the analysis equal the numpy formulations they replaced, bit for bit.

Edge cases the seeded synthetic captures of ``test_reference_results`` may miss: steps of exactly
±π and multiples of 2π (numpy's ambiguous unwrap boundary), wraps and violations at block
boundaries, samples exactly on bin edges, repeated angle values (zero-width segments), a last
edge clipped to the record, steps all equal (np.histogram's widened range), sums that overflow.
"""

from __future__ import annotations

import numpy as np
import pytest

from hil.analysis.angle import (SCAN_BLOCK, TWO_PI, _first_non_increasing, _unwrap_and_survey,
                                check_finite, check_time, travel_angle)
from hil.analysis.resample import (HISTOGRAM_BLOCK, STEP_HISTOGRAM_BINS, _bin_averages,
                                   interpolation_response)
from hil.analysis.uncertainty import _draw_sums
from hil.errors import InputError


def _bits(values: np.ndarray) -> np.ndarray:
    return np.asarray(values, dtype=np.float64).view(np.int64)


def _angles(rng: np.random.Generator):
    """Angle records with every kind of step, some longer than one scan block."""
    n = 3 * SCAN_BLOCK + 17
    yield np.mod(np.cumsum(rng.normal(0.2, 0.5, n)), TWO_PI)              # wrapped, forwards
    yield np.mod(-np.cumsum(rng.uniform(0.0, 0.3, n)), TWO_PI)            # wrapped, backwards
    yield np.cumsum(rng.choice([np.pi, -np.pi, TWO_PI, -3 * np.pi, 0.1, 0.0], n))
    yield np.round(rng.normal(0.0, 4.0, n)) * np.pi                     # exact multiples of π
    yield rng.uniform(-50.0, 50.0, 999)                                  # noise
    steady = np.cumsum(rng.uniform(1e-3, 1e-2, n))
    steady[[SCAN_BLOCK, SCAN_BLOCK + 1, 2 * SCAN_BLOCK + 5]] -= 4.0      # wraps at block edges
    yield steady
    yield np.array([-0.0, 0.0, -0.0, 3.5, -3.5])


def test_unwrap_is_numpy_bit_for_bit_with_its_monotonicity():
    for angle in _angles(np.random.default_rng(7)):
        unwrapped = np.empty_like(angle)
        increasing, decreasing = _unwrap_and_survey(angle, unwrapped)
        expected = np.unwrap(angle, period=TWO_PI)
        np.testing.assert_array_equal(_bits(unwrapped), _bits(expected))
        assert increasing == bool((np.diff(expected) > 0).all())
        assert decreasing == bool((np.diff(expected) < 0).all())


def test_travel_of_a_monotonic_angle_is_the_unwrapped_angle_and_the_input_is_untouched():
    time_s = np.arange(2 * SCAN_BLOCK) * 1e-4
    for direction in (1, -1):
        angle = np.mod(direction * (0.4 + 300.0 * time_s), TWO_PI)
        kept = angle.copy()
        travel = travel_angle(time_s, angle)
        assert travel.direction == direction
        np.testing.assert_array_equal(_bits(travel.travel_rad),
                                      _bits(direction * np.unwrap(kept, period=TWO_PI)))
        np.testing.assert_array_equal(_bits(angle), _bits(kept))


@pytest.mark.parametrize("index", [1, 2, SCAN_BLOCK - 1, SCAN_BLOCK, SCAN_BLOCK + 1,
                                   2 * SCAN_BLOCK + 3])
def test_first_non_increasing_sample_is_found_in_any_block(index):
    time_s = np.arange(2 * SCAN_BLOCK + 4, dtype=np.float64)
    assert _first_non_increasing(time_s) == 0
    time_s[index] = time_s[index - 1]
    assert _first_non_increasing(time_s) == index
    with pytest.raises(InputError, match=f"sample {index} is at"):
        check_time(time_s)


def test_finite_check_survives_an_overflowing_sum_and_names_the_first_bad_sample():
    huge = np.full(10, 1e308)                          # finite, but the sum overflows to inf
    assert check_finite("torque_nm", huge) is not None
    values = np.zeros(100)
    values[[17, 40]] = (np.nan, -np.inf)
    with pytest.raises(InputError, match="2 non-finite .* first at index 17"):
        check_finite("torque_nm", values)


def _numpy_histogram_response(travel_rad, max_order):
    steps = np.diff(travel_rad)
    weights, edges = np.histogram(steps, bins=STEP_HISTOGRAM_BINS, weights=steps)
    centres = 0.5 * (edges[1:] + edges[:-1])
    gain = np.sinc(np.arange(max_order + 1)[:, None] * centres[None, :] / TWO_PI) ** 2
    return (gain @ weights) / float(weights.sum())


@pytest.mark.parametrize("kind", ["noisy", "equal steps", "on the edges", "repeats"])
def test_step_histogram_response_is_numpy_bit_for_bit(kind):
    rng = np.random.default_rng(11)
    n = 2 * HISTOGRAM_BLOCK + 123
    if kind == "noisy":
        steps = rng.uniform(1e-3, 5e-3, n)
    elif kind == "equal steps":
        steps = np.full(n, 2.0 ** -9)                  # np.histogram widens the range by ±0.5
    elif kind == "on the edges":
        steps = rng.integers(0, STEP_HISTOGRAM_BINS + 1, n) * 2.0 ** -12
    else:
        steps = rng.choice([0.0, 1e-3, 3e-3], n)
    travel = np.concatenate(([0.5], 0.5 + np.cumsum(steps)))
    np.testing.assert_array_equal(_bits(interpolation_response(travel, 48)),
                                  _bits(_numpy_histogram_response(travel, 48)))


def _numpy_bin_averages(s, torque, n_bins, revolutions, first_edge, reverse):
    """The angle-average bins as the numpy formulation computed them (cumulative trapezoid
    integral from s[0], evaluated at the edges found by searchsorted)."""
    bin_rad = TWO_PI / n_bins
    edges = (first_edge + np.arange(revolutions * n_bins + 1)) * bin_rad
    edges[-1] = min(edges[-1], s[-1])
    offset = float(np.mean(torque))
    tau = torque - offset
    ds = np.diff(s)
    cumulative = np.concatenate(([0.0], np.cumsum(0.5 * (tau[1:] + tau[:-1]) * ds)))
    index = np.clip(np.searchsorted(s, edges, side="right") - 1, 0, s.size - 2)
    u = edges - s[index]
    with np.errstate(divide="ignore", invalid="ignore"):
        slope = np.where(ds[index] > 0, (tau[index + 1] - tau[index]) / ds[index], 0.0)
    integral = (cumulative[index] + tau[index] * u + 0.5 * slope * u * u
                + offset * (edges - s[0]))
    matrix = np.roll((np.diff(integral) / bin_rad).reshape(revolutions, n_bins),
                     first_edge % n_bins, axis=1)
    return matrix[:, ::-1] if reverse else matrix


@pytest.mark.parametrize("samples_per_bin", [0.3, 1.0, 2.9, 40.0])
@pytest.mark.parametrize("reverse", [False, True])
def test_bin_averages_are_the_numpy_formulation_bit_for_bit(samples_per_bin, reverse):
    rng = np.random.default_rng(5)
    n_bins = 64
    bin_rad = TWO_PI / n_bins
    n = int(samples_per_bin * n_bins * 3.7)
    if samples_per_bin == 1.0:                     # every sample exactly on an edge, some twice
        s = np.sort(rng.integers(-2 * n_bins, int(1.7 * n_bins), n)) * bin_rad
    else:
        s = 0.3 + np.cumsum(rng.uniform(0.5, 1.5, n)) * bin_rad / samples_per_bin
    torque = 1.0 + 0.1 * np.cos(3.0 * s) + rng.normal(0.0, 0.01, n)
    first_edge = int(np.ceil(s[0] / bin_rad))
    revolutions = int(np.floor((s[-1] - first_edge * bin_rad) / TWO_PI + 1e-9))
    matrix = np.empty((revolutions, n_bins))
    _bin_averages(s, torque, float(np.mean(torque)), first_edge, bin_rad, first_edge % n_bins,
                  reverse, matrix)
    np.testing.assert_array_equal(
        _bits(matrix), _bits(_numpy_bin_averages(s, torque, n_bins, revolutions, first_edge,
                                                 reverse)))


def test_bootstrap_draw_sums_equal_the_matrix_products():
    rng = np.random.default_rng(3)
    counts = rng.multinomial(50, np.full(50, 1 / 50), size=20)
    block_sums = rng.normal(size=(50, 9)) + 1j * rng.normal(size=(50, 9))
    block_sizes = rng.integers(1, 4, 50).astype(np.float64)
    sums, sizes = _draw_sums(counts, block_sums.view(np.float64), block_sizes)
    np.testing.assert_allclose(sums.view(np.complex128), counts @ block_sums, rtol=1e-13,
                               atol=1e-13)
    np.testing.assert_array_equal(sizes, counts @ block_sizes)


def test_strided_read_only_and_byte_swapped_channels_give_the_same_result():
    """Captures may hold columns of one table, memory-mapped (read-only) or big-endian files."""
    from hil.analysis import analyze_torque

    time_s = np.arange(6000) / 1e4
    angle = np.mod(2 * np.pi * 40.0 * time_s, TWO_PI)
    torque = 1.0 + 0.02 * np.cos(6 * angle) + np.random.default_rng(2).normal(0.0, 0.01, 6000)
    plain = analyze_torque(time_s, torque, angle, max_order=16)
    table = np.stack([time_s, torque, angle], axis=1)
    read_only = [channel.copy() for channel in (time_s, torque, angle)]
    for channel in read_only:
        channel.setflags(write=False)
    for channels in ((table[:, 0], table[:, 1], table[:, 2]), read_only,
                     [channel.astype(">f8") for channel in (time_s, torque, angle)]):
        result = analyze_torque(*channels, max_order=16)
        np.testing.assert_array_equal(result.revolution_matrix_nm, plain.revolution_matrix_nm)
        assert result.pk_pk_pu == plain.pk_pk_pu
