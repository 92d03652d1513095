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
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hil.errors import InputError

TWO_PI = 2.0 * np.pi
#: Backward motion (electrical rad) accepted as encoder jitter and flattened; more is an error.
DEFAULT_JITTER_TOLERANCE_RAD = np.deg2rad(5.0)


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
    bad = ~np.isfinite(values)
    if bad.any():
        raise InputError(f"channel {name!r} has {int(bad.sum())} non-finite (NaN/inf) samples, "
                         f"first at index {int(np.argmax(bad))}; all samples must be finite")
    return values


def check_time(time_s: np.ndarray) -> np.ndarray:
    """Validate a sample-time channel: finite and strictly increasing (InputError otherwise)."""
    time_s = check_finite("time_s", time_s)
    steps = np.diff(time_s)
    if steps.size and not (steps > 0).all():
        index = int(np.argmax(steps <= 0)) + 1
        raise InputError(f"channel 'time_s' is not strictly increasing: sample {index} is at "
                         f"{time_s[index]!r} s after {time_s[index - 1]!r} s")
    return time_s


def travel_angle(time_s: np.ndarray, angle_elec_rad: np.ndarray, *,
                 jitter_tolerance_rad: float = DEFAULT_JITTER_TOLERANCE_RAD) -> TravelAngle:
    """Unwrap, orient, de-jitter and de-quantise an electrical angle (see the module docstring).

    ``time_s`` must already be validated by :func:`check_time`. Raises InputError if the angle
    never advances or runs backwards by more than ``jitter_tolerance_rad`` (electrical radians).
    """
    angle = np.unwrap(check_finite("rotor angle", angle_elec_rad), period=TWO_PI)
    net = angle[-1] - angle[0]
    if not net > 0 and not net < 0:
        raise InputError("the rotor angle never advances (net travel 0 electrical rad); "
                         "angle-domain analysis needs a turning rotor")
    direction = 1 if net > 0 else -1
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


def angle_from_speed(time_s: np.ndarray, speed_rpm: np.ndarray) -> np.ndarray:
    """Mechanical angle (rad, zero at the first sample) integrated from a speed channel (rpm)."""
    omega = check_finite("speed_rpm", speed_rpm) * (TWO_PI / 60.0)
    increments = 0.5 * (omega[1:] + omega[:-1]) * np.diff(time_s)
    return np.concatenate(([0.0], np.cumsum(increments)))
