"""Rotor angle for angle-domain analysis: validate, unwrap, orient, make monotonic.

The analysis resamples torque onto the rotor's *electrical* angle, so it needs a time→angle map
that only moves forward. This module turns whatever the capture holds (a wrapped or unwrapped
mechanical angle, encoder counts, or only a speed) into a non-decreasing "travel" angle:

* unwrapped with period 2π (a wrapped angle jumps back by a multiple of 2π each turn);
* oriented: a rotor turning backwards (negative speed) is analysed along ``-θ`` and the result is
  mapped back onto the true angle by :mod:`hil.analysis.resample`;
* de-jittered: backward steps up to ``jitter_tolerance_rad`` (an encoder dithering by a count at
  standstill) are flattened; larger backward motion is an input error;
* de-quantised: an angle from encoder counts is a staircase (at low speed many samples share a
  count). Each run of equal values is replaced by one anchor at the run's mid-time, and the angle is
  linearly interpolated between anchors, so every torque sample gets its own angle and weight
  (stepping the rotor slowly — how the paper measured the encoder effect — still resamples on
  angle).
  A strictly increasing angle passes through unchanged.

Speed (issue 17): the unwrap and the monotonicity checks are one compiled pass
(:func:`_unwrap_and_survey`) that reproduces ``np.unwrap`` bit for bit; a strictly monotonic
angle (the usual capture) needs nothing more, anything else continues in numpy. Compiled code
states ``fastmath=False`` (see :mod:`hil.sim.kernel`): the results must equal numpy's exactly.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from hil.errors import InputError

TWO_PI = 2.0 * np.pi
#: Backward motion (electrical rad) accepted as encoder jitter and flattened; more is an error.
DEFAULT_JITTER_TOLERANCE_RAD = np.deg2rad(5.0)
#: Samples per block of the compiled scans (a block is first tested branch-free, vectorised).
SCAN_BLOCK = 4096


@dataclass(frozen=True)
class TravelAngle:
    """A non-decreasing electrical travel angle ``travel_rad = direction * θ_e`` per sample."""

    travel_rad: np.ndarray
    direction: int          # +1: θ_e increases with time, -1: it decreases


def check_finite(name: str, values: np.ndarray) -> np.ndarray:
    """Return ``values`` as float64; InputError naming the channel if any sample is NaN or inf."""
    try:
        values = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"channel {name!r} must hold numbers, got "
                         f"{np.asarray(values).dtype} values") from None
    if values.ndim != 1:
        raise InputError(f"channel {name!r} must be one-dimensional, got shape {values.shape}")
    with np.errstate(all="ignore"):
        total = np.add.reduce(values)
    if math.isfinite(total):
        return values               # a NaN or inf would make the sum non-finite (one fast pass)
    bad = ~np.isfinite(values)
    if bad.any():
        raise InputError(f"channel {name!r} has {int(bad.sum())} non-finite (NaN/inf) samples, "
                         f"first at index {int(np.argmax(bad))}; all samples must be finite")
    return values


def check_time(time_s: np.ndarray) -> np.ndarray:
    """Validate a sample-time channel: finite and strictly increasing (InputError otherwise)."""
    time_s = check_finite("time_s", time_s)
    index = _first_non_increasing(time_s)
    if index > 0:
        raise InputError(f"channel 'time_s' is not strictly increasing: sample {index} is at "
                         f"{time_s[index]!r} s after {time_s[index - 1]!r} s")
    return time_s


def travel_angle(time_s: np.ndarray, angle_elec_rad: np.ndarray, *,
                 jitter_tolerance_rad: float = DEFAULT_JITTER_TOLERANCE_RAD) -> TravelAngle:
    """Unwrap, orient, de-jitter and de-quantise an electrical angle (see the module docstring).

    ``time_s`` must already be validated by :func:`check_time`. Raises InputError if the angle
    never advances or runs backwards by more than ``jitter_tolerance_rad`` (electrical radians).
    """
    wrapped = check_finite("rotor angle", angle_elec_rad)
    angle = np.empty_like(wrapped)
    increasing, decreasing = _unwrap_and_survey(wrapped, angle)
    net = angle[-1] - angle[0]
    if not net > 0 and not net < 0:
        raise InputError("the rotor angle never advances (net travel 0 electrical rad); "
                         "angle-domain analysis needs a turning rotor")
    direction = 1 if net > 0 else -1
    if increasing if direction > 0 else decreasing:
        # strictly monotonic: nothing to flatten or interpolate, the travel is ±angle itself
        return TravelAngle(travel_rad=angle if direction > 0 else np.negative(angle, out=angle),
                           direction=direction)
    travel = angle if direction > 0 else -angle
    envelope = np.maximum.accumulate(travel)
    backward = envelope - travel
    worst = int(np.argmax(backward))
    if backward[worst] > jitter_tolerance_rad:
        raise InputError(
            f"the rotor angle runs backwards by {np.rad2deg(backward[worst]):.3g} electrical deg "
            f"at t = {time_s[worst]:.6g} s (allowed jitter "
            f"{np.rad2deg(jitter_tolerance_rad):.3g} deg); the time->angle map must be monotonic")
    return TravelAngle(travel_rad=_dequantize(time_s, envelope), direction=direction)


def _dequantize(time_s: np.ndarray, travel: np.ndarray) -> np.ndarray:
    """Replace runs of equal angle values by interpolation between the runs' mid-time anchors."""
    starts = np.flatnonzero(np.diff(travel) > 0) + 1
    if starts.size == travel.size - 1:
        return travel                                   # strictly increasing already
    starts = np.concatenate(([0], starts))
    ends = np.concatenate((starts[1:] - 1, [travel.size - 1]))
    anchor_t = 0.5 * (time_s[starts] + time_s[ends])
    anchor_angle = travel[starts]
    if starts.size >= 4:                                # first and last runs are cut by the record
        anchor_t, anchor_angle = anchor_t[1:-1], anchor_angle[1:-1]
    return np.interp(time_s, anchor_t, anchor_angle)


@njit(cache=True, error_model="numpy", fastmath=False)
def _first_non_increasing(values: np.ndarray) -> int:
    """Index of the first sample not above its predecessor; 0 if the (finite) channel strictly
    increases. Each block of SCAN_BLOCK samples is first tested branch-free (vectorised)."""
    for start in range(1, values.size, SCAN_BLOCK):
        stop = min(start + SCAN_BLOCK, values.size)
        before, after = values[start - 1:stop - 1], values[start:stop]
        bad = 0
        for i in range(stop - start):
            bad |= np.int64(after[i] <= before[i])
        if bad:
            for i in range(stop - start):
                if after[i] <= before[i]:
                    return start + i
    return 0


@njit(cache=True, error_model="numpy", fastmath=False)
def _unwrap_and_survey(angle: np.ndarray, unwrapped: np.ndarray):
    """``unwrapped[:] = np.unwrap(angle, period=2π)`` bit for bit, in one pass; returns whether
    the result strictly increases and whether it strictly decreases. (``unwrapped`` is allocated
    by numpy, whose large arrays get transparent huge pages: far fewer page faults.)

    numpy's recipe per step ``d``: if ``|d| ≥ π``, the correction ``((d + π) mod 2π) − π − d``
    (``π`` replacing an exact ``−π`` when ``d > 0``) is added to a running sum that offsets all
    later samples. A block of SCAN_BLOCK samples without such a step is a vectorised add.
    """
    increasing = decreasing = True
    if angle.size == 0:
        return increasing, decreasing
    unwrapped[0] = angle[0]
    correction = 0.0
    for start in range(1, angle.size, SCAN_BLOCK):
        stop = min(start + SCAN_BLOCK, angle.size)
        before, after = angle[start - 1:stop - 1], angle[start:stop]
        out_before, out = unwrapped[start - 1:stop - 1], unwrapped[start:stop]
        wraps = 0
        for i in range(stop - start):
            wraps |= np.int64(abs(after[i] - before[i]) >= math.pi)
        if wraps:
            for i in range(stop - start):
                step = after[i] - before[i]
                if abs(step) >= math.pi:
                    wrapped = np.fmod(step + math.pi, TWO_PI)   # numpy's float mod (divisor > 0)
                    if wrapped < 0.0:
                        wrapped += TWO_PI
                    elif wrapped == 0.0:
                        wrapped = 0.0
                    wrapped = wrapped + -math.pi
                    if wrapped == -math.pi and step > 0.0:
                        wrapped = math.pi
                    correction += wrapped - step
                out[i] = after[i] + correction
        else:
            for i in range(stop - start):
                out[i] = after[i] + correction
        not_up = not_down = 0
        for i in range(stop - start):
            not_up |= np.int64(out[i] <= out_before[i])
            not_down |= np.int64(out[i] >= out_before[i])
        increasing &= not_up == 0
        decreasing &= not_down == 0
    return increasing, decreasing


def angle_from_speed(time_s: np.ndarray, speed_rpm: np.ndarray) -> np.ndarray:
    """Mechanical angle (rad, zero at the first sample) integrated from a speed channel (rpm)."""
    omega = check_finite("speed_rpm", speed_rpm) * (TWO_PI / 60.0)
    increments = 0.5 * (omega[1:] + omega[:-1]) * np.diff(time_s)
    return np.concatenate(([0.0], np.cumsum(increments)))
