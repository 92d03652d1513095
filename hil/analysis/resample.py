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
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hil.analysis.angle import TWO_PI, TravelAngle
from hil.errors import InputError

MIN_SAMPLES_PER_REV = 64
POINTS_PER_PERIOD = 8   # grid points per period of the highest order of interest


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
    edges = (first_edge + np.arange(revolutions * n_bins + 1)) * bin_rad
    edges[-1] = min(edges[-1], s[-1])
    bins = np.diff(_angle_integral(s, torque_nm, edges)) / bin_rad
    matrix = np.roll(bins.reshape(revolutions, n_bins), first_edge % n_bins, axis=1)
    if travel.direction < 0:
        matrix = matrix[:, ::-1]           # travel bin j is electrical-angle bin N-1-j
    grid = (np.arange(n_bins) + 0.5) * bin_rad
    return RevolutionMatrix(matrix_nm=np.ascontiguousarray(matrix), angle_grid_rad=grid)


def _angle_integral(s: np.ndarray, torque: np.ndarray, points: np.ndarray) -> np.ndarray:
    """∫ τ ds from s[0] to each of ``points`` for the piecewise-linear interpolant τ(s), plus a
    constant offset·(point − s[0]) so the offset cancels in bin averages (improves rounding)."""
    offset = float(np.mean(torque))
    tau = np.asarray(torque, dtype=np.float64) - offset
    ds = np.diff(s)
    cumulative = np.empty_like(s)
    cumulative[0] = 0.0
    np.cumsum(0.5 * (tau[1:] + tau[:-1]) * ds, out=cumulative[1:])
    index = np.clip(np.searchsorted(s, points, side="right") - 1, 0, s.size - 2)
    u = points - s[index]
    width = ds[index]
    with np.errstate(divide="ignore", invalid="ignore"):
        slope = np.where(width > 0, (tau[index + 1] - tau[index]) / width, 0.0)
    return cumulative[index] + tau[index] * u + 0.5 * slope * u * u + offset * (points - s[0])


def interpolation_response(travel_rad: np.ndarray, max_order: int) -> np.ndarray:
    """Gain of orders 0..``max_order`` through the piecewise-linear interpolant of the samples.

    The angle step δ between samples varies with speed; each step passes order k with
    ``sinc²(k·δ/2π)``, weighted by the angle δ it covers (a 256-bin histogram of δ keeps this
    O(samples)).
    """
    steps = np.diff(travel_rad)
    weights, bin_edges = np.histogram(steps, bins=256, weights=steps)
    centres = 0.5 * (bin_edges[1:] + bin_edges[:-1])
    total = float(weights.sum())
    orders = np.arange(max_order + 1)[:, None]
    gain = np.sinc(orders * centres[None, :] / TWO_PI) ** 2
    return (gain @ weights) / total
