"""Angle-domain resampling: torque samples → a matrix of whole electrical revolutions × angle bins.

Each bin value is the *angle average* of the torque over the bin, ``(1/Δ)∫ τ dθ`` with ``Δ = 2π/N``,
computed exactly for the piecewise-linear interpolant of the samples (a cumulative integral over
angle, evaluated at the bin edges). So every sample contributes, weighted by the angle it spans:
at high speed with few samples per bin it reduces to linear interpolation, at low speed it averages
the many samples in a bin, and a varying speed needs no correction. The bin average is a boxcar
of width Δ in angle; its response to order k, ``sinc(k/N)``, is removed in
:mod:`hil.analysis.spectrum`. The linear interpolant between samples δ apart (electrical rad)
passes order k with gain ``sinc²(k·δ/2π)`` (its triangle kernel); :func:`interpolation_response`
gives that gain averaged over the record so the spectrum can remove it too (it matters when a
high order has few samples per period, e.g. order 36 at 11 samples per period: −2.7 %).

Bins are aligned to the absolute electrical angle (bin j covers ``[jΔ, (j+1)Δ)`` mod 2π) so the
phases of the order spectrum refer to the rotor's electrical zero. A revolution is N consecutive
bins; the record keeps ``floor(travel / 2π)`` whole revolutions starting at the first bin edge, so a
record of 7.3 revolutions gives 7.

Speed (issue 17): the cumulative integral, its evaluation at the bin edges (a merge of two sorted
sequences instead of a binary search), the bin averages and their placement in the matrix are one
compiled pass over the samples (:func:`_bin_averages`); the weighted histogram of angle steps
is two (:func:`_step_range`, :func:`_step_histogram`). They reproduce the numpy formulation
they replaced operation for operation, under ``fastmath=False`` (see :mod:`hil.sim.kernel`),
so the results are unchanged bit for bit.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from hil.analysis.angle import TWO_PI, TravelAngle
from hil.errors import InputError

MIN_SAMPLES_PER_REV = 64
POINTS_PER_PERIOD = 8   # grid points per period of the highest order of interest
STEP_HISTOGRAM_BINS = 256
#: Samples summed per partial histogram before adding to the total (numpy's np.histogram block).
HISTOGRAM_BLOCK = 65536


def samples_per_revolution(max_order: int) -> int:
    """Angle-grid size N: a power of two with at least 8 points per period of ``max_order``."""
    if not 1 <= int(max_order) <= 4096:
        raise InputError(f"max_order must be an integer in 1..4096, got {max_order!r}")
    return max(MIN_SAMPLES_PER_REV, 1 << int(np.ceil(np.log2(POINTS_PER_PERIOD * int(max_order)))))


@dataclass(frozen=True)
class RevolutionMatrix:
    """Angle-averaged torque, one row per whole electrical revolution (in time order).

    ``matrix_nm[r, j]`` is revolution r's mean torque over electrical angle bin j, whose centre is
    ``angle_grid_rad[j] = (j + 0.5)·2π/N``.
    """

    matrix_nm: np.ndarray
    angle_grid_rad: np.ndarray

    @property
    def revolutions(self) -> int:
        return self.matrix_nm.shape[0]

    @property
    def samples_per_rev(self) -> int:
        return self.matrix_nm.shape[1]


def resample_revolutions(travel: TravelAngle, torque_nm: np.ndarray,
                         samples_per_rev: int) -> RevolutionMatrix:
    """Bin-average ``torque_nm`` over the whole electrical revolutions of ``travel``."""
    s = travel.travel_rad
    n_bins = int(samples_per_rev)
    bin_rad = TWO_PI / n_bins
    first_edge = int(np.ceil(s[0] / bin_rad))
    span_rev = (s[-1] - first_edge * bin_rad) / TWO_PI
    revolutions = int(np.floor(span_rev + 1e-9))
    if revolutions < 1:
        raise InputError(f"the capture covers only {max((s[-1] - s[0]) / TWO_PI, 0.0):.3g} "
                         "electrical revolutions; at least one whole revolution is needed")
    matrix = np.empty((revolutions, n_bins))        # numpy's allocation: huge pages
    _bin_averages(s, np.asarray(torque_nm, dtype=np.float64), float(np.mean(torque_nm)),
                  first_edge, bin_rad, first_edge % n_bins, travel.direction < 0, matrix)
    grid = (np.arange(n_bins) + 0.5) * bin_rad
    return RevolutionMatrix(matrix_nm=matrix, angle_grid_rad=grid)


@njit(cache=True, error_model="numpy", fastmath=False)
def _bin_averages(s, torque, offset, first_edge, bin_rad, shift, reverse, matrix):
    """Fill the revolutions × bins ``matrix`` with ``(1/Δ)∫ τ ds`` over the bins
    ``[(first_edge + k)·Δ, (first_edge + k + 1)·Δ)``.

    The integral of the piecewise-linear interpolant ``τ(s)`` runs from ``s[0]`` as a cumulative
    trapezoid sum; at each edge ``e`` (the last one clipped to ``s[-1]``) it is completed by the
    partial segment from the last sample ``i`` with ``s[i] ≤ e`` (``0 ≤ i ≤ n − 2``). The offset
    (the mean torque) is integrated separately, ``offset·(e − s[0])``, so it cancels in the
    differences (better rounding). Bin k of revolution r lands in column ``(k + shift) mod N``
    (bins aligned to the absolute electrical angle), mirrored when the rotor turns backwards.
    """
    n = s.size
    revolutions, n_bins = matrix.shape
    total = revolutions * n_bins
    start = s[0]
    i = 0
    cumulative = 0.0
    previous = 0.0
    row = column = 0                       # where bin k − 1 goes: revolution, bin within it
    for k in range(total + 1):
        edge = float(first_edge + k) * bin_rad
        if k == total and edge > s[n - 1]:
            edge = s[n - 1]
        while i < n - 2 and s[i + 1] <= edge:          # the trapezoid of segment i, in order
            cumulative += (0.5 * ((torque[i + 1] - offset) + (torque[i] - offset))
                           * (s[i + 1] - s[i]))
            i += 1
        tau = torque[i] - offset
        u = edge - s[i]
        width = s[i + 1] - s[i]
        slope = ((torque[i + 1] - offset) - tau) / width if width > 0 else 0.0
        integral = cumulative + tau * u + 0.5 * slope * u * u + offset * (edge - start)
        if k > 0:
            place = column + shift if column + shift < n_bins else column + shift - n_bins
            matrix[row, n_bins - 1 - place if reverse else place] = (integral - previous) / bin_rad
            column += 1
            if column == n_bins:
                row, column = row + 1, 0
        previous = integral


def interpolation_response(travel_rad: np.ndarray, max_order: int) -> np.ndarray:
    """Gain of orders 0..``max_order`` through the piecewise-linear interpolant of the samples.

    The angle step δ between samples varies with speed; each step passes order k with
    ``sinc²(k·δ/2π)``, weighted by the angle δ it covers (a 256-bin histogram of δ keeps this
    O(samples)).
    """
    if travel_rad.size < 2:
        raise InputError("the interpolation response needs at least two angle samples")
    lowest, highest = _step_range(travel_rad)
    if lowest == highest:                                 # as np.histogram widens an empty range
        lowest, highest = lowest - 0.5, highest + 0.5
    bin_edges = np.linspace(lowest, highest, STEP_HISTOGRAM_BINS + 1)
    weights = _step_histogram(travel_rad, bin_edges)
    centres = 0.5 * (bin_edges[1:] + bin_edges[:-1])
    total = float(weights.sum())
    orders = np.arange(max_order + 1)[:, None]
    gain = np.sinc(orders * centres[None, :] / TWO_PI) ** 2
    return (gain @ weights) / total


@njit(cache=True, error_model="numpy", fastmath=False)
def _step_range(s):
    """Smallest and largest step ``s[i+1] − s[i]`` (rad)."""
    lowest = highest = s[1] - s[0]
    for i in range(1, s.size - 1):
        step = s[i + 1] - s[i]
        if step < lowest:
            lowest = step
        elif step > highest:
            highest = step
    return lowest, highest


@njit(cache=True, error_model="numpy", fastmath=False)
def _step_histogram(s, bin_edges):
    """``np.histogram(steps, bin_edges, weights=steps)[0]`` of the steps of ``s``, bit for bit:
    the same bin for each step (numpy's estimate from the equal spacing, then its one-ulp
    corrections against the edges; the last bin closed) and the same order of summation (per
    bin in sample order, in partial sums over blocks of HISTOGRAM_BLOCK steps added to the total).
    The first estimate of a block is a branch-free (vectorised) loop."""
    n_bins = bin_edges.size - 1
    first, span = bin_edges[0], bin_edges[n_bins] - bin_edges[0]
    total = np.zeros(n_bins)
    partial = np.empty(n_bins)
    estimate = np.empty(HISTOGRAM_BLOCK, dtype=np.int64)
    steps = s.size - 1
    for block in range(0, steps, HISTOGRAM_BLOCK):
        stop = min(block + HISTOGRAM_BLOCK, steps)
        before, after = s[block:stop], s[block + 1:stop + 1]
        for i in range(stop - block):
            estimate[i] = np.int64((after[i] - before[i] - first) / span * n_bins)
        partial[:] = 0.0
        current, running = -1, 0.0           # the bin being summed, kept in a register
        for i in range(stop - block):
            step = after[i] - before[i]
            index = min(estimate[i], n_bins - 1)
            if step < bin_edges[index]:
                index -= 1
            if step >= bin_edges[index + 1] and index != n_bins - 1:
                index += 1
            if index != current:
                if current >= 0:
                    partial[current] = running
                current, running = index, partial[index]
            running += step
        if current >= 0:
            partial[current] = running
        for j in range(n_bins):
            total[j] += partial[j]
    return total
