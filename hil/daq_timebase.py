"""The DAQ's time base against physics the bench has (issue 30 item 4; design.md §7, kind 3).

The self-check's speed check compares the encoder's slope over the DAQ's stamps with the dyno's
setpoint: a DAQ clock 0.5 % slow read 0.5025 % fast against a 0.5 % tolerance — caught by
0.013 rpm at 500 rpm, and missed by a 0.4 % one — and sample instants that jitter by ±3/8 of a
sample with the tick count nominal were not seen at all. Two references the bench carries do
see them:

* **the PWM line** (:func:`pwm_line`): the drive's switching ripple in the phase currents sits
  at 2·f_pwm ± k·f_e (centre-aligned SVPWM; f_pwm from the drive's crystal, a few tens of ppm)
  and, sampled at the stated rate f_s, appears aliased at a frequency known exactly. A DAQ whose
  clock runs at c·f_s stamps it at that alias of 2·f_pwm/c: the line's centre measured in the
  stamped time base gives c with a resolution of ppm (the alias multiplies the clock error by
  2·f_pwm/f_alias). A jittered sampling instant turns the line's phase by 2π·2·f_pwm·δt: at
  ±3/8 of a 7919 Hz sample that is ±1.9 turns, so the line is no longer a line — its share of
  the current's non-synchronous power collapses.
* **the encoder** (:func:`encoder_sample_instants`): at a held speed the angle channel advances
  v counts per sample; the second difference of a quantised ramp is −1, 0 or +1, while a sample
  taken δ late moves the reading by v·δ counts: the RMS of the second difference grows by
  v·σ_δ·√6.

The line must be present: a DAQ with an anti-aliasing filter below the alias removes it (then
the PWM-line check fails and says so; state such a DAQ's clock check by other means). Bands:
``hil/model/README.md`` ("DAQ time base"), calibrated on one set of motors and points and checked
on a disjoint one (``studies/daq_timebase_calibration.py``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hil.capture import Capture
from hil.selfcheck import check, electrical_angle

#: Synchronous orders removed from the currents before the line is looked for.
SYNCHRONOUS_ORDERS = 40
#: Orders always removed and never searched: the line's window keeps above LOW_ORDERS·f_e.
LOW_ORDERS = 3
#: Highest electrical frequency at which the PWM line is judged, Hz: the calibration set's
#: highest (Table I at 1000 rpm, 33 Hz) × 1.2. Beyond it the ±f_e sidebands and the window's
#: other content bias the line's centre (holdout: 14 poles at 800 rpm, 93 Hz, read −670 ppm),
#: so no PWM-line check is made there (hil/model/README.md "DAQ time base").
MAX_LINE_ELEC_HZ = 40.0
#: How far from the stated rate the line is searched for (relative clock error).
SEARCH_PU = 0.008


@dataclass(frozen=True)
class PwmLine:
    """The 2·f_pwm line in a capture's currents (module docstring); NaN share: the electrical
    frequency is above ``MAX_LINE_ELEC_HZ`` or the line's alias lies among the lowest orders,
    where it cannot be told from them — no PWM-line check there."""

    clock_scale: float            # real sample rate / stated rate, from the line's centre
    line_share: float             # the line's share of the non-synchronous current power
    expected_alias_hz: float      # where the line sits with a true clock
    measured_alias_hz: float


def _alias(frequency_hz: float, rate_hz: float) -> tuple[float, int, int]:
    """(alias in 0..rate/2, fold m, sign s) with alias = s·(frequency − m·rate)."""
    m = round(frequency_hz / rate_hz)
    alias = frequency_hz - m * rate_hz
    return abs(alias), m, (1 if alias >= 0 else -1)


def _residual(capture: Capture, channel: str, pole_pairs: int, rate_hz: float,
              keep_hz: tuple[float, float]) -> np.ndarray:
    """The channel less its synchronous part (orders 0..K of the electrical angle, least
    squares, except those inside ``keep_hz``, where the line is searched): the switching ripple
    and noise."""
    theta = electrical_angle(capture, pole_pairs)
    x = np.asarray(capture[channel], dtype=float)
    span = abs(theta[-1] - theta[0]) / (2 * math.pi)
    elec_hz = span / (len(x) / rate_hz) if len(x) else 0.0
    orders = int(min(SYNCHRONOUS_ORDERS, 0.45 * rate_hz / elec_hz)) if elec_hz > 0 else 0
    columns = [np.ones_like(theta)]
    for k in range(1, orders + 1):
        if k > LOW_ORDERS and keep_hz[0] <= k * elec_hz <= keep_hz[1]:
            continue
        columns += [np.cos(k * theta), np.sin(k * theta)]
    basis = np.column_stack(columns)
    coef, *_ = np.linalg.lstsq(basis, x, rcond=None)
    return x - basis @ coef


def pwm_line(capture: Capture, pwm_frequency_hz: float, pole_pairs: int,
             rate_hz: float) -> PwmLine:
    """Locate the aliased 2·f_pwm line in the phase currents (module docstring)."""
    time_s = np.asarray(capture["time_s"], dtype=float)
    n = len(time_s)
    freqs = np.fft.rfftfreq(n, 1.0 / rate_hz)
    df = rate_hz / n
    theta = electrical_angle(capture, pole_pairs)
    elec_hz = abs(theta[-1] - theta[0]) / (2 * math.pi) / (n / rate_hz)
    half_width = 2.0 * elec_hz + 3.0 * df
    carrier = 2.0 * pwm_frequency_hz
    expected, fold, sign = _alias(carrier, rate_hz)
    # orders 1..LOW_ORDERS are always removed; the window keeps clear of the fundamental's
    # region (the dyno's own speed ripple and the removal's residue sit there)
    low_cut = 1.5 * elec_hz + 3.0 * df
    if elec_hz > MAX_LINE_ELEC_HZ or not (low_cut <= expected - half_width
                                          and expected + half_width <= rate_hz / 2):
        return PwmLine(math.nan, math.nan, expected, math.nan)
    scales = np.linspace(1.0 - SEARCH_PU, 1.0 + SEARCH_PU, 1601)
    aliases = sign * (carrier / scales - fold * rate_hz)
    usable = (aliases - half_width >= low_cut) & (aliases <= rate_hz / 2 - half_width)
    if not usable.any():
        return PwmLine(math.nan, 0.0, expected, math.nan)
    keep = (float(aliases[usable].min()) - half_width, float(aliases[usable].max()) + half_width)
    window = np.hanning(n)
    power = np.zeros(n // 2 + 1)
    for channel in ("ia_a", "ib_a"):
        if channel in capture:
            residual = _residual(capture, channel, pole_pairs, rate_hz, keep)
            power += np.abs(np.fft.rfft(residual * window)) ** 2
    total = float(power[freqs >= low_cut].sum())
    cumulative = np.concatenate([[0.0], np.cumsum(power)])
    low = np.searchsorted(freqs, aliases - half_width, side="left")
    high = np.searchsorted(freqs, aliases + half_width, side="right")
    inside = np.where(usable, cumulative[high] - cumulative[low], -1.0)
    pick = int(np.argmax(inside))
    if inside[pick] <= 0 or total <= 0:
        return PwmLine(math.nan, 0.0, expected, math.nan)
    best = (float(inside[pick]), float(scales[pick]))
    guess = sign * (carrier / best[1] - fold * rate_hz)
    band = (freqs >= guess - half_width) & (freqs <= guess + half_width)
    centroid = float(np.sum(freqs[band] * power[band]) / np.sum(power[band]))
    centre = _cluster_centre(freqs, power, centroid, half_width, elec_hz, df)
    clock = carrier / (fold * rate_hz + sign * centre)
    return PwmLine(clock, best[0] / total, expected, centre)


#: Lines of the cluster used for its centre: those within this fraction of the strongest's power.
LINE_POWER_SHARE = 0.1


def _cluster_centre(freqs, power, guess: float, half_width: float, elec_hz: float,
                    df: float) -> float:
    """The carrier's alias from the cluster's lines: each line (a local maximum within the
    window, interpolated on the log spectrum) sits at centre + k·f_e exactly, so centre =
    f_line − k·f_e with k the nearest integer to its distance from the power centroid
    ``guess``; weighted by power. (A power centroid is pulled by
    the sidebands' asymmetry: ±f_e lines of unequal power moved it by up to (A₊² − A₋²)/(A₊² +
    A₋²)·f_e, −400 ppm of clock on a 10-pole 48 V motor braking at 400 rpm.)"""
    index = np.flatnonzero((freqs >= guess - half_width) & (freqs <= guess + half_width))
    index = index[(index > 0) & (index < len(power) - 1)]
    peaks = [i for i in index if power[i] >= power[i - 1] and power[i] > power[i + 1]]
    if not peaks:
        return guess
    strongest = max(power[i] for i in peaks)
    centres, weights = [], []
    for i in peaks:
        if power[i] < LINE_POWER_SHARE * strongest:
            continue
        a, b, c = np.log(power[i - 1:i + 2] + 1e-300)
        shift = 0.5 * (a - c) / (a - 2.0 * b + c) if (a - 2.0 * b + c) != 0 else 0.0
        line_hz = freqs[i] + shift * df
        k = round((line_hz - guess) / elec_hz) if elec_hz > 0 else 0
        centres.append(line_hz - k * elec_hz)
        weights.append(power[i])
    return float(np.average(centres, weights=weights)) if centres else guess


def pwm_line_checks(capture: Capture, pwm_frequency_hz: float, pole_pairs: int,
                    rate_hz: float, *, clock_tolerance_pu: float) -> list[dict]:
    """The DAQ clock from the PWM line (one check; none where the line cannot be judged). The
    line's share of the non-synchronous power is recorded in the check (``line_share``), not
    judged: a correct Table I drive at −500 rpm / 30 A read 0.33 against 0.67–0.81 on the
    calibration set (more of the cluster lies outside the window at high current), so no band
    from that set holds; jittered sample instants are judged by the encoder check."""
    line = pwm_line(capture, pwm_frequency_hz, pole_pairs, rate_hz)
    if math.isnan(line.line_share):
        return []          # the line's alias sits among the low orders at this speed: no check
    out = check("DAQ clock (PWM line)", line.clock_scale, 1.0, "1", clock_tolerance_pu,
                f"real / stated sample rate from the drive's PWM line in the currents (2·f_pwm "
                f"= {2 * pwm_frequency_hz:g} Hz aliased to {line.expected_alias_hz:.1f} Hz at "
                f"the stated {rate_hz:g} Hz; found at {line.measured_alias_hz:.2f} Hz; line "
                f"share {line.line_share:.3f})")
    out["line_share"] = line.line_share
    return [out]


def encoder_second_difference_rms(capture: Capture, counts_per_rev: int) -> tuple[float, float]:
    """(RMS of the angle channel's second difference in counts, counts advanced per sample)."""
    mech = np.unwrap(np.asarray(capture["rotor_angle_mech_rad"], dtype=float))
    counts = np.round(mech * counts_per_rev / (2 * math.pi))
    second = np.diff(counts, 2)
    per_sample = float(np.mean(np.abs(np.diff(counts)))) if len(counts) > 1 else 0.0
    return (float(np.sqrt(np.mean(second ** 2))) if second.size else math.nan), per_sample


def encoder_sample_instants(capture: Capture, counts_per_rev: int, *,
                            max_rms_counts: float) -> dict:
    """The angle channel's second difference against a quantised ramp's (module docstring)."""
    rms, per_sample = encoder_second_difference_rms(capture, counts_per_rev)
    return check("DAQ sample instants (encoder)", rms, 0.0, "counts", max_rms_counts,
                 f"RMS second difference of the angle channel at {per_sample:.3g} counts per "
                 f"sample (a quantised ramp: ≤ 1; an instant δ off moves it by "
                 f"{per_sample:.3g}·δ counts)")
