"""PWM switching ripple measured electrically (paper section III-D, eqs 29-31, Fig. 9).

A torque transducer (≈ 1 kHz bandwidth) cannot see ripple at the switching frequency, so the
air-gap torque is *estimated* from the phase currents sampled fast and the encoder angle:

    T̂ = Σ_x e_x·i_x / ω_m = K·[i_a·sin θ + i_b·sin(θ − 2π/3) + i_c·sin(θ + 2π/3)],
    i_c = −i_a − i_b

with θ the electrical angle, K = E/ω_m = √2·Ke the nameplate EMF constant (sinusoidal EMF,
:class:`hil.motor.MotorParameters`) and the neutral isolated — equivalently (3/2)·p·ψ·i_q. This is
a measurement-based estimate that assumes the nameplate EMF; it is not the paper's closed form,
and no prediction formula is used here. Ke and a gain error common to both current sensors cancel
in the per-unit figure.

The ripple is then split by PWM period and summarised the way eqs 29-31 describe it:

1. **Windows.** The record (from its first sample, by time stamp) is cut into windows of G whole
   PWM periods, G = the largest integer whose window spans at most :data:`MAX_WINDOW_ANGLE_RAD`
   of electrical angle (at least 1). Any window of whole periods holds every phase of a periodic
   ripple, so its pk-pk is the within-period pk-pk wherever the window starts. With G > 1 and a
   sample rate that is not an integer multiple of f_pwm the sample phases walk through the period
   from one period to the next (equivalent-time sampling), so a DAQ limited to a few samples per
   period still finds the extremes. The *effective samples per period* is T_s divided by the
   largest gap between the sample phases (modulo T_s) in a window; fewer than
   :data:`MIN_EFFECTIVE_SAMPLES_PER_PERIOD` is refused (InputError).
2. **Envelope.** pk-pk of T̂ within each window → an envelope series at the window centres'
   electrical angles (Fig. 9's pk-pk per PWM period; the paper's envelope repeats every 60°,
   order 6).
3. **Angle analysis.** The envelope and the window means of T̂ go through the same chain as
   :func:`hil.analysis.analyze_torque`: resampled on whole electrical revolutions, order spectrum,
   synchronous average, bootstrap type-A over revolutions.

The metric — the quantity eqs 30-31 predict — is the **largest within-period pk-pk**: the maximum
over angle of the synchronously averaged envelope (band-limited to ``max_order``), per unit of the
mean of T̂. The paper's figure is the pk-pk current ripple 2·Δi at its worst angle (the voltage
zero crossing) per unit of I, taken equal to the per-unit torque ripple.

Fields of the returned :class:`~hil.analysis.metrics.RippleResult` (same type as
``analyze_capture``, so ``decide`` and the record work unchanged):

* ``mean_torque_nm``: mean of T̂ over the whole revolutions analysed;
* ``pk_pk_nm``/``pk_pk_pu``: the largest within-period pk-pk of T̂ (above), in N·m / per unit of
  ``|mean_torque_nm|``; ``pk_pk_method`` = :data:`PK_PK_METHOD`;
* ``orders``/``amplitude_nm``/``phase_rad``/``amplitude_u_nm``/``dominant_order``/``rms_ac_nm``:
  the order spectrum of the *envelope* (N·m of within-period pk-pk), so ``dominant_order`` is the
  envelope's order (6 expected); ``named_order`` = 6;
* ``angle_grid_rad``/``sync_average_nm``/``revolution_matrix_nm``: the envelope's synchronous
  average and its per-revolution angle bins;
* ``uncertainty``: type A and noise bias as in :mod:`hil.analysis.uncertainty`; the sampling
  bias (extremes falling between sample phases read low), bounded in each window by the corner
  where the lines through the samples on either side of its largest (and smallest) sample meet
  — T̂ is piecewise linear within a PWM period — on the window's samples folded onto one period,
  averaged over the windows of each angle bin as the envelope is, the largest bin kept, added
  linearly (an estimated bound: a segment shorter than the
  sample spacing near an extreme escapes it); and the
  current channels' DAQ resolution (meta ``daq_lsb``). The notes give G and the effective
  samples per period.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from hil.analysis.angle import TWO_PI, TravelAngle, check_finite, check_time, travel_angle
from hil.analysis.metrics import RippleResult, spectrum_fields
from hil.analysis.resample import (interpolation_response, resample_revolutions,
                                   samples_per_revolution)
from hil.analysis.spectrum import order_coefficients, reconstruct
from hil.analysis.uncertainty import COVERAGE_FACTOR, BudgetRow, UncertaintyBudget, type_a
from hil.capture import Capture
from hil.errors import InputError
from hil.motor import MotorParameters

#: Longest window (electrical rad): 3°, 1/20 of the order-6 envelope's period.
MAX_WINDOW_ANGLE_RAD = math.pi / 60.0
#: Fewer effective samples per PWM period than this cannot locate the ripple's extremes.
MIN_EFFECTIVE_SAMPLES_PER_PERIOD = 8
#: The envelope order of eqs 29-31 (the ripple's pk-pk repeats every 60° electrical).
ENVELOPE_ORDER = 6
#: ``RippleResult.pk_pk_method`` of this analysis.
PK_PK_METHOD = "max within-PWM-period pk-pk (envelope)"
#: Grid points per period of ``max_order`` on which the envelope's maximum is searched.
PEAK_SEARCH_POINTS_PER_PERIOD = 64
PHASE_OFFSETS_RAD = (0.0, 2.0 * math.pi / 3.0, -2.0 * math.pi / 3.0)


def estimated_torque_nm(ia_a: np.ndarray, ib_a: np.ndarray, angle_elec_rad: np.ndarray,
                        motor: MotorParameters) -> np.ndarray:
    """T̂ = Σ e_x·i_x/ω_m from two phase currents (isolated neutral) and the electrical angle.

    e_x/ω_m = √2·Ke·sin(θ − o_x), o_x = 0, 2π/3, −2π/3 (nameplate sinusoidal EMF, paper eq 1).
    """
    currents = (ia_a, ib_a, -ia_a - ib_a)
    torque = np.zeros_like(angle_elec_rad)
    for current, offset in zip(currents, PHASE_OFFSETS_RAD):
        torque += current * np.sin(angle_elec_rad - offset)
    return motor.emf_peak_v_s_per_rad * torque


def analyze_switching(capture: Capture, *, pwm_frequency_hz: float, motor: MotorParameters,
                      max_order: int = 48, instruments=None) -> RippleResult:
    """Largest within-PWM-period pk-pk of the estimated torque T̂ and its envelope (eqs 29-31).

    Needs channels ``time_s``, ``ia_a``, ``ib_a`` and ``rotor_angle_mech_rad`` (else
    ``encoder_counts`` with meta ``encoder_counts_per_rev``); pole pairs from meta ``pole_pairs``
    (else ``motor``). ``instruments`` (the transducer chain's type-B data) is accepted so that the
    call matches ``analyze_capture``; the transducer does not enter this estimate, which the
    budget notes. Raises InputError for missing channels, a bad ``pwm_frequency_hz``, fewer than
    8 effective samples per PWM period, too few windows per revolution for ``max_order``, or the
    checks of the angle analysis. See the module docstring for the definitions.
    """
    if not isinstance(motor, MotorParameters):
        raise InputError(f"motor must be a MotorParameters, got {type(motor).__name__}")
    if isinstance(pwm_frequency_hz, bool) or not isinstance(pwm_frequency_hz, (int, float)) \
            or not (math.isfinite(pwm_frequency_hz) and pwm_frequency_hz > 0):
        raise InputError(f"pwm_frequency_hz={pwm_frequency_hz!r} must be a positive number (Hz)")
    if isinstance(max_order, bool) or not isinstance(max_order, (int, np.integer)) \
            or not 1 <= max_order <= 4096:
        raise InputError(f"max_order must be an integer in 1..4096, got {max_order!r}")
    missing = [name for name in ("time_s", "ia_a", "ib_a") if name not in capture]
    if missing:
        raise InputError(f"switching analysis needs capture channels {missing}; "
                         f"it has {sorted(capture.channels)}")
    time_s = check_time(capture["time_s"])
    ia = check_finite("ia_a", capture["ia_a"])
    ib = check_finite("ib_a", capture["ib_a"])
    mech = _mechanical_angle(capture)
    if not time_s.size == ia.size == ib.size == mech.size:
        raise InputError(f"channels time_s ({time_s.size}), ia_a ({ia.size}), ib_a ({ib.size}) "
                         f"and the angle ({mech.size}) must have the same number of samples")
    if time_s.size < 2 * MIN_EFFECTIVE_SAMPLES_PER_PERIOD:
        raise InputError(f"the capture has {time_s.size} samples; too few for a PWM analysis")
    pole_pairs = _pole_pairs(capture, motor)
    travel = travel_angle(time_s, pole_pairs * mech)
    angle = travel.direction * travel.travel_rad
    torque = estimated_torque_nm(ia, ib, angle, motor)

    windows = _windows(time_s, travel, float(pwm_frequency_hz))
    _check_windows(windows, pwm_frequency_hz, max_order)
    centre_travel = np.interp(windows.centre_s, time_s, travel.travel_rad)
    centres = TravelAngle(travel_rad=centre_travel, direction=travel.direction)
    n_bins = samples_per_revolution(max_order)
    response = interpolation_response(centre_travel, max_order)
    used = torque[:windows.stop]
    env_revs, per_rev = _envelope_revolutions(used, windows, centres, n_bins, max_order, response)
    window_mean_nm = np.add.reduceat(used, windows.starts) / np.diff(
        np.append(windows.starts, windows.stop))
    per_rev_mean = resample_revolutions(centres, window_mean_nm, n_bins).matrix_nm.mean(axis=1)
    coefficients = per_rev.mean(axis=0)
    mean_nm = float(per_rev_mean.mean())
    peak_nm = float(_band_limited_max(coefficients[None, :])[0])
    pk_pk_pu = peak_nm / abs(mean_nm) if mean_nm != 0 else math.nan
    amplitude, phase = np.abs(coefficients[1:]), np.angle(coefficients[1:])
    # extremes between sample phases read low: bounded per window from the neighbouring slopes
    sampling_bias_nm = _sampling_bias_bound_nm(used, time_s[:windows.stop], windows, centres,
                                               n_bins)
    budget = _budget(per_rev, per_rev_mean, pk_pk_pu, mean_nm, sampling_bias_nm, windows,
                     capture, motor, instruments)
    named = ENVELOPE_ORDER if ENVELOPE_ORDER <= max_order else None
    return RippleResult(
        mean_torque_nm=mean_nm, pk_pk_nm=peak_nm, pk_pk_pu=pk_pk_pu, pk_pk_rated_pu=None,
        rated_torque_nm=None, **spectrum_fields(amplitude, phase, per_rev, named),
        pk_pk_method=PK_PK_METHOD,
        revolutions=env_revs.revolutions, samples_per_rev=env_revs.samples_per_rev,
        max_order=int(max_order), direction=travel.direction,
        angle_grid_rad=env_revs.angle_grid_rad,
        sync_average_nm=reconstruct(coefficients, env_revs.samples_per_rev, centred=True),
        revolution_matrix_nm=env_revs.matrix_nm, uncertainty=budget)


def window_periods(elec_speed_rad_s: float, pwm_frequency_hz: float) -> int:
    """G: PWM periods per analysis window, the most whose span stays within
    :data:`MAX_WINDOW_ANGLE_RAD` of electrical angle at ``elec_speed_rad_s`` (at least 1)."""
    return max(1, int(MAX_WINDOW_ANGLE_RAD * pwm_frequency_hz / abs(elec_speed_rad_s) + 1e-6))


def effective_samples_per_period(sample_rate_hz: float, pwm_frequency_hz: float,
                                 periods: int, windows: int = 24) -> float:
    """T_s over the largest gap between sample phases (mod T_s) in a window of ``periods`` PWM
    periods, worst over the first ``windows`` windows of a capture sampled at ``sample_rate_hz``
    from t = 0 (what :func:`analyze_switching` finds on such a capture)."""
    period_s = 1.0 / pwm_frequency_hz
    window_s = periods * period_s
    samples = int(math.ceil(windows * window_s * sample_rate_hz)) + 1
    return period_s / _uniform_largest_phase_gap(float(sample_rate_hz), period_s, window_s,
                                                 int(windows), samples)


@njit(cache=True, error_model="numpy")
def _uniform_largest_phase_gap(sample_rate_hz, period_s, window_s, windows, samples):
    """:func:`_largest_phase_gap` of the samples k/f_s (k < ``samples``) in the windows
    ⌊t/window_s + 1e-9⌋ < ``windows``, the same arithmetic sample by sample, compiled:
    :func:`capture_settings` asks it of thousands of candidate rates (1 s of the default run's
    pre-flight as numpy array work, issue 33)."""
    largest = 0.0
    phases = np.empty(samples)
    k = 0
    for window in range(windows):
        count = 0
        while k < samples:
            t = k / sample_rate_hz
            if np.floor(t / window_s + 1e-9) > window:
                break
            phases[count] = np.mod(t, period_s)
            count += 1
            k += 1
        if count == 0:
            continue
        ordered = np.sort(phases[:count])
        for i in range(1, count):
            largest = max(largest, ordered[i] - ordered[i - 1])
        largest = max(largest, period_s - ordered[count - 1] + ordered[0])
    return largest


def synchronous_grid(sample_rate_hz: float, pwm_frequency_hz: float, periods: int,
                     windows_per_revolution: float, revolutions: int = 8) -> bool:
    """Whether the windows' sample phases sit at (nearly) the same place against the carrier at
    the same electrical angle in every revolution of a capture of ``revolutions``. The corners
    the samples miss move with the duty cycles, so the misses then form a pattern synchronous
    with the rotor that the revolutions' average keeps (8-pole motor at 1000 rpm, 5 A, 20 kHz:
    190 kHz in windows of 2 periods read an envelope of orders 3, 6, 9 with 1/7 of the order-6
    amplitude of the 10 kHz point, a wrong rejection on the signature); otherwise the
    arrangement at an angle changes from revolution to revolution and the average dithers the
    misses out.

    Exactly: the same phases in every window (G·f_s/f_pwm whole), or an arrangement cycle
    fitting a revolution a whole number of times. Nearly (a rate rounded to whole Hz, or the
    beat of the window's phase grid, b = G·f_s − N·f_pwm with N = round(G·f_s/f_pwm), a whole
    number of times f_e): at :data:`DITHER_ANGLES` angles of a revolution, where one window
    holds fewer than :data:`DENSE_SAMPLES_PER_PERIOD` effective samples per period, the phases
    of the windows at that angle in all the revolutions together must give at least
    :data:`MIN_DITHER_RATIO` times one window's. 10-pole motor at 1200 rpm, 40 kHz,
    windows of 3 periods: 186667 Hz (14/3·f_pwm + ⅓ Hz, b = 1 Hz) and 187 kHz (b = 1 kHz =
    10·f_e) both repeat every revolution (ratio 1.08); the envelope's order 6 read 3e-5 N·m
    where 1e-3 was due."""
    rate, pwm = float(sample_rate_hz), float(pwm_frequency_hz)
    cycles = periods * rate / pwm
    if abs(cycles - round(cycles)) < 1e-9 * max(1.0, cycles):
        return True
    if rate.is_integer() and pwm.is_integer():
        cycle = int(pwm) // math.gcd(int(pwm), periods * int(rate))   # windows per cycle
        per_cycle = windows_per_revolution / cycle
        if abs(per_cycle - round(per_cycle)) < 1e-6:
            return True
    period_s = 1.0 / pwm
    window_s = periods * period_s
    offsets = np.round(windows_per_revolution * np.arange(max(1, revolutions))).astype(np.int64)
    for angle in range(DITHER_ANGLES):
        first = int(round(angle * windows_per_revolution / DITHER_ANGLES))
        phases = [_window_phases(first + k, window_s, period_s, rate) for k in offsets]
        single = period_s / _circular_gap(phases[0], period_s)
        if single >= DENSE_SAMPLES_PER_PERIOD:
            continue                # one window alone leaves no corner worth a pattern
        union = period_s / _circular_gap(np.concatenate(phases), period_s)
        if union / single < MIN_DITHER_RATIO:
            return True
    return False


#: :func:`synchronous_grid`: angles of a revolution checked, and the least gain in effective
#: samples per period the revolutions' union must bring (1: every revolution repeats the same
#: arrangement; R: each of R revolutions adds its own).
DITHER_ANGLES = 8
MIN_DITHER_RATIO = 2.0
#: ... applied where one window holds fewer effective samples per period than this (4 × the
#: minimum: where :func:`capture_settings` stops looking for more).
DENSE_SAMPLES_PER_PERIOD = 4 * MIN_EFFECTIVE_SAMPLES_PER_PERIOD


def _window_phases(index: int, window_s: float, period_s: float, rate_hz: float) -> np.ndarray:
    """Sample phases (s, mod T_s) of window ``index`` of a capture sampled from t = 0."""
    first = math.ceil(index * window_s * rate_hz - 1e-9)
    stop = math.ceil((index + 1) * window_s * rate_hz - 1e-9)
    return np.mod(np.arange(first, stop) / rate_hz, period_s)


def _circular_gap(phase_s: np.ndarray, period_s: float) -> float:
    """Largest gap between phases on the circle of one PWM period."""
    ordered = np.sort(phase_s)
    return float(max(np.diff(ordered).max(initial=0.0), period_s - ordered[-1] + ordered[0]))


def capture_effective_samples_per_period(sample_rate_hz: float, pwm_frequency_hz: float,
                                         window_lengths, capture_periods: float) -> float:
    """The effective samples per PWM period :func:`analyze_switching` finds on a capture of
    ``capture_periods`` PWM periods sampled at ``sample_rate_hz`` from t = 0: the worst window of
    the capture, worst over the window lengths G it may take (``window_lengths``). Window k
    starts k·G·f_s/f_pwm sample intervals after the first sample, so the arrangements of sample
    phases repeat after f_pwm/gcd(f_pwm, G·f_s) windows for whole-Hz rates: only those (or all
    the capture's windows, if fewer) are evaluated."""
    rate, pwm = float(sample_rate_hz), float(pwm_frequency_hz)
    worst = math.inf
    for g in window_lengths:
        windows = max(1, int(capture_periods // g))
        if rate.is_integer() and pwm.is_integer():
            windows = min(windows, int(pwm) // math.gcd(int(pwm), g * int(rate)))
        worst = min(worst, effective_samples_per_period(rate, pwm, g, windows=windows))
    return worst


@dataclass(frozen=True)
class CaptureSettings:
    """A DAQ rate and record length for the switching analysis at one speed and PWM frequency."""

    sample_rate_hz: float
    revolutions: int
    window_periods: int             # G at the nominal speed
    effective_samples_per_period: float   # worst over the window lengths the analysis may take


#: Relative speed error (measured against nominal) for which the analysis may take G ± 1: the
#: rate must then suit those windows as well.
SPEED_MARGIN = 0.005
#: Largest denominator K of the fractions q = j/K of f_s = f_pwm·(n + q) tried.
MAX_FRACTION_DENOMINATOR = 40


@functools.lru_cache(maxsize=256)
def capture_settings(speed_rpm: float, pole_pairs: int, pwm_frequency_hz: float, *,
                     max_sample_rate_hz: float, buffer_samples: int, max_order: int,
                     revolutions: int = 8, min_revolutions: int = 4) -> CaptureSettings | str:
    """The DAQ rate and revolutions for :func:`analyze_switching` at this speed and PWM frequency,
    or the reason (a string) why this DAQ cannot capture it.

    Rates f_s = f_pwm·(n + j/K) ≤ ``max_sample_rate_hz``, rounded to whole Hz
    (K ≤ MAX_FRACTION_DENOMINATOR, never an integer multiple, so the sample phases walk through the PWM period from one period to the
    next), each with as many revolutions (≤ ``revolutions``, ≥ ``min_revolutions``) as
    ``buffer_samples`` holds for the capture of revolutions + ¼. The rate kept has the most
    effective samples per period in windows of G periods — and of G ± 1 where a speed error of
    SPEED_MARGIN moves the analysis there — more revolutions breaking ties. Refused (the reason
    returned): fewer than MIN_EFFECTIVE_SAMPLES_PER_PERIOD at every rate, too few windows per
    revolution for ``max_order``, or a buffer too small for ``min_revolutions``.
    """
    elec_hz = abs(speed_rpm) * pole_pairs / 60.0
    if elec_hz <= 0.0:
        return "speed 0: the switching analysis needs whole electrical revolutions"
    omega_e = 2.0 * math.pi * elec_hz
    periods = window_periods(omega_e, pwm_frequency_hz)
    per_revolution = pwm_frequency_hz / (elec_hz * periods)
    if per_revolution <= 2 * max_order:
        return (f"{per_revolution:.3g} PWM windows per electrical revolution at {speed_rpm:g} rpm "
                f"and {pwm_frequency_hz:g} Hz; max_order {max_order} needs more than "
                f"{2 * max_order}")
    lengths = sorted({window_periods(omega_e * (1.0 + e), pwm_frequency_hz)
                      for e in (-SPEED_MARGIN, 0.0, SPEED_MARGIN)})
    fractions = sorted({j / k for k in range(2, MAX_FRACTION_DENOMINATOR + 1)
                        for j in range(1, k) if math.gcd(j, k) == 1})
    # the rates f_pwm·(n + q) for each n, fastest first; a rate's first 8 windows bound its
    # effective samples per period from above (the capture's worst window is never better), and
    # the rates are checked on the windows the capture really holds in that order: the sample
    # phases of a window repeat only after the rate's whole pattern (up to f_pwm/gcd windows), so
    # the first windows can promise more than the capture gives (199.5 kHz at 20 kHz in windows
    # of one period: 9.97 in the first 8 windows, 5.05 in the 40th, which holds 9 samples)
    best, best_key = None, None
    for n in range(int(max_sample_rate_hz // pwm_frequency_hz), 0, -1):
        if best is not None and best.effective_samples_per_period >= (n + 1) * lengths[0]:
            break                   # no slower rate can give more samples per window
        candidates = set()
        for q in fractions:
            rate = float(round(pwm_frequency_hz * (n + q)))   # a DAQ takes whole Hz
            revs = min(revolutions, int(buffer_samples * elec_hz / rate - 0.25))
            if rate > max_sample_rate_hz or revs < min_revolutions:
                continue
            bound = min(effective_samples_per_period(rate, pwm_frequency_hz, g, windows=8)
                        for g in lengths)
            candidates.add((round(bound, 6), revs, rate))
        for bound, revs, rate in sorted(candidates, reverse=True):
            if best_key is not None and (bound, revs) <= best_key:
                break               # no other rate of this n can do better
            if synchronous_grid(rate, pwm_frequency_hz, periods, per_revolution, revs):
                continue
            effective = capture_effective_samples_per_period(
                rate, pwm_frequency_hz, lengths, (revs + 0.25) * pwm_frequency_hz / elec_hz)
            key = (round(effective, 6), revs)
            if best_key is None or key > best_key:
                best, best_key = CaptureSettings(rate, revs, periods, effective), key
        if best is not None and best.effective_samples_per_period >= 4 * \
                MIN_EFFECTIVE_SAMPLES_PER_PERIOD:
            break                   # slower rates only lose samples per period
    if best is None:
        return (f"the DAQ buffer ({buffer_samples} samples) cannot hold {min_revolutions} "
                f"electrical revolutions at {speed_rpm:g} rpm above {pwm_frequency_hz:g} Hz")
    if best.effective_samples_per_period < MIN_EFFECTIVE_SAMPLES_PER_PERIOD:
        return (f"at most {best.effective_samples_per_period:.3g} effective samples per PWM period "
                f"of {pwm_frequency_hz:g} Hz at {speed_rpm:g} rpm with the DAQ's "
                f"{max_sample_rate_hz:g} S/s (at least {MIN_EFFECTIVE_SAMPLES_PER_PERIOD} needed)")
    return best


@dataclass(frozen=True)
class _Windows:
    """Complete windows of ``periods`` whole PWM periods over samples ``[0, stop)``."""

    starts: np.ndarray              # first sample index of each window
    stop: int                       # one past the last sample of the last window
    periods: int                    # G, PWM periods per window
    period_s: float                 # T_s
    centre_s: np.ndarray            # time stamp of each window's centre
    largest_gap_s: float            # largest gap between sample phases (mod T_s) in a window
    per_revolution: float           # windows per electrical revolution

    @property
    def effective_samples_per_period(self) -> float:
        return self.period_s / self.largest_gap_s


def _windows(time_s: np.ndarray, travel: TravelAngle, pwm_frequency_hz: float) -> _Windows:
    """Cut the record into complete windows of G PWM periods (module docstring, step 1)."""
    period_s = 1.0 / pwm_frequency_hz
    duration_s = time_s[-1] - time_s[0]
    speed = (travel.travel_rad[-1] - travel.travel_rad[0]) / duration_s     # electrical rad/s
    periods = window_periods(speed, pwm_frequency_hz)
    window_s = periods * period_s
    elapsed = time_s - time_s[0]
    index = np.floor(elapsed / window_s + 1e-9).astype(np.int64)
    # a window is complete if the record goes on to (or past) its end
    count = int(np.floor((duration_s + np.median(np.diff(time_s))) / window_s + 1e-9))
    count = min(count, int(index[-1]) + 1)
    if count < 1:
        raise InputError(f"the capture ({duration_s:.3g} s) is shorter than one PWM window "
                         f"({window_s:.3g} s)")
    starts = np.searchsorted(index, np.arange(count))
    stop = int(np.searchsorted(index, count))
    if np.any(np.diff(np.append(starts, stop)) == 0):
        raise InputError("some PWM windows hold no sample: the sample rate is far too low for "
                         f"pwm_frequency_hz={pwm_frequency_hz:g}")
    phase = np.mod(elapsed[:stop], period_s)
    largest_gap = _largest_phase_gap(phase, index[:stop], period_s)
    centre_s = time_s[0] + (np.arange(count) + 0.5) * window_s
    return _Windows(starts, stop, periods, period_s, centre_s, largest_gap,
                    TWO_PI / (speed * window_s))


def _largest_phase_gap(phase_s: np.ndarray, window: np.ndarray, period_s: float) -> float:
    """Largest gap between the sample phases (mod T_s) within any window, wrap included."""
    order = np.lexsort((phase_s, window))
    phase_s, window = phase_s[order], window[order]
    first = np.flatnonzero(np.diff(window, prepend=-1) != 0)
    last = np.append(first[1:], phase_s.size) - 1
    gaps = np.diff(phase_s)
    gaps[np.diff(window) != 0] = 0.0
    wrap = period_s - phase_s[last] + phase_s[first]
    return max(float(gaps.max(initial=0.0)), float(wrap.max()))


@njit(cache=True, error_model="numpy")
def _corner_excess(phase_s, value, period_s):
    """How far the true maximum of a piecewise-linear periodic waveform (period ``period_s``)
    may lie above its largest sample: the two lines through the samples on either side of the
    largest one meet at the corner, which lies between the largest sample and one of its
    neighbours (both cases taken, the larger kept; a line that does not rise towards the corner
    bounds nothing and counts 0). Samples at the same phase (a window longer than the rate's
    phase pattern, e.g. 195 kHz at 20 kHz repeats every 4 periods, in windows of 5) are one
    point, the largest value kept: a zero phase step would make the slopes undefined (NaN).
    Compiled: the analysis asks it twice per PWM window (issue 33)."""
    by_value = np.argsort(-value, kind="mergesort")       # phase first, larger value first
    order = by_value[np.argsort(phase_s[by_value], kind="mergesort")]
    p, v = phase_s[order], value[order]
    first = np.ones(p.size, dtype=np.bool_)
    first[1:] = np.diff(p) > 1e-9 * period_s
    p, v = p[first], v[first]
    if p.size < 5:
        return 0.0
    m = np.argmax(v)
    pp = np.empty(5)
    vv = np.empty(5)
    for j in range(5):
        i = m - 2 + j
        pp[j] = p[i % p.size] + (i // p.size) * period_s
        vv[j] = v[i % p.size]
    slopes = np.diff(vv) / np.diff(pp)            # between m-2, m-1, m, m+1, m+2
    after = _corner_meet(slopes[1], -slopes[3], pp[3] - pp[2], vv[3] - vv[2])
    before = _corner_meet(-slopes[2], slopes[0], pp[2] - pp[1], vv[1] - vv[2])
    return max(after, before)


@njit(cache=True, error_model="numpy")
def _corner_meet(rise_slope, fall_slope, gap, step):
    """Rise above the sample of the lines of ``rise_slope`` and ``fall_slope`` where they meet
    within ``gap`` (0: a line that does not rise towards the corner bounds nothing)."""
    if not (rise_slope > 0 and fall_slope > 0 and gap > 0):
        return 0.0
    return rise_slope * min(max((step + fall_slope * gap) / (rise_slope + fall_slope), 0.0), gap)


def _sampling_bias_bound_nm(torque_nm: np.ndarray, time_s: np.ndarray, windows: _Windows,
                            centres: TravelAngle, n_bins: int) -> float:
    """How far the synchronously averaged envelope's maximum may read below the true one: each
    window's pk-pk reads low by at most the corner excess (:func:`_corner_excess`) of its maximum
    plus that of its minimum, on its samples folded onto one PWM period (equivalent time); the
    average of the windows in an angle bin by at most their bounds' average; the largest bin
    average over the revolutions' bins is kept."""
    phase = np.mod(time_s - time_s[0], windows.period_s)
    bounds = np.append(windows.starts, windows.stop)
    per_window = np.zeros(windows.starts.size)
    for k, (start, stop) in enumerate(zip(bounds[:-1], bounds[1:])):
        if stop - start >= 5:
            p, v = phase[start:stop], torque_nm[start:stop]
            per_window[k] = _corner_excess(p, v, windows.period_s) + \
                _corner_excess(p, -v, windows.period_s)
    binned = resample_revolutions(centres, per_window, n_bins).matrix_nm.mean(axis=0)
    return float(max(binned.max(), 0.0))


def _envelope_revolutions(torque_nm, windows, centres, n_bins, max_order, response):
    """pk-pk of T̂ in each window, binned on whole revolutions, and its
    per-revolution order coefficients."""
    envelope_nm = np.maximum.reduceat(torque_nm, windows.starts) - \
        np.minimum.reduceat(torque_nm, windows.starts)
    revs = resample_revolutions(centres, envelope_nm, n_bins)
    return revs, order_coefficients(revs.matrix_nm, int(max_order), response)


def _check_windows(windows: _Windows, pwm_frequency_hz: float, max_order: int) -> None:
    effective = windows.effective_samples_per_period
    if effective < MIN_EFFECTIVE_SAMPLES_PER_PERIOD:
        raise InputError(
            f"the sample rate gives {effective:.3g} effective samples per PWM period of "
            f"pwm_frequency_hz={pwm_frequency_hz:g} (windows of {windows.periods} periods); at "
            f"least {MIN_EFFECTIVE_SAMPLES_PER_PERIOD} are needed: sample faster, or at a rate "
            "that is not an integer multiple of the PWM frequency (equivalent-time sampling)")
    if windows.per_revolution <= 2 * max_order:
        raise InputError(
            f"max_order={max_order} needs more than {2 * max_order} envelope points per "
            f"electrical revolution; windows of {windows.periods} PWM periods give "
            f"{windows.per_revolution:.3g}: lower max_order or raise pwm_frequency_hz/slow down")


def _band_limited_max(coefficients: np.ndarray) -> np.ndarray:
    """Maximum over angle of each row's Fourier series (c_0..c_K), on a fine grid."""
    max_order = coefficients.shape[-1] - 1
    points = max(256, PEAK_SEARCH_POINTS_PER_PERIOD * max_order)
    return reconstruct(coefficients, points).max(axis=-1)


def _budget(per_rev, per_rev_mean, pk_pk_pu, mean_nm, sampling_bias_nm, windows, capture,
            motor, instruments) -> UncertaintyBudget:
    """Type A, noise bias, sampling bias bound and DAQ current resolution of ``pk_pk_pu``."""
    width = per_rev.shape[1]
    rows_a = np.concatenate([per_rev, per_rev_mean[:, None].astype(np.complex128)], axis=1)

    def statistic(rows: np.ndarray) -> np.ndarray:
        with np.errstate(divide="ignore", invalid="ignore"):
            return _band_limited_max(rows[:, :width]) / np.abs(rows[:, width].real)

    scatter = type_a(rows_a, statistic)
    mean_abs = abs(mean_nm)
    revolutions = per_rev.shape[0]
    rows = [BudgetRow(f"type A: revolution scatter ({revolutions} revs, bootstrap)",
                      scatter.standard_pu, "pu", "normal", 1.0, 1.0, "1", scatter.standard_pu),
            BudgetRow("residual noise bias of sync-average envelope maximum", scatter.bias_pu,
                      "pu", "bias (added linearly)", 1.0, 1.0, "1", abs(scatter.bias_pu),
                      combination="linear")]
    rows.append(BudgetRow(f"sampling: extremes between sample phases (largest gap "
                          f"{windows.largest_gap_s:.3g} s; corner of the neighbouring slopes, "
                          "worst angle bin)",
                          sampling_bias_nm, "N*m", "bias bound (reads low; added linearly)", 1.0,
                          1.0 / mean_abs, "1/(N*m)", sampling_bias_nm / mean_abs,
                          combination="linear"))
    notes = [f"torque T̂ from ia, ib and the encoder angle with the nameplate EMF; windows of "
             f"{windows.periods} PWM periods, {windows.effective_samples_per_period:.3g} "
             "effective samples per period",
             "Ke and a gain error common to both current sensors cancel in the per-unit figure"]
    lsb = (capture.meta.get("daq_lsb") or {}).get("ia_a")
    if isinstance(lsb, (int, float)) and lsb > 0:
        # one T̂ reading carries K·(c_a·e_a + c_b·e_b), mean-square c_a² + c_b² = 3, e ~ U(±LSB/2):
        # std K·LSB/2; the pk-pk is a difference of two readings: K·LSB/√2
        rows.append(BudgetRow("type B: DAQ current resolution (1 LSB of ia, ib), on pk-pk",
                              float(lsb), "A", "rectangular, 2 readings x 2 channels",
                              math.sqrt(2.0), motor.emf_peak_v_s_per_rad / mean_abs, "N*m/A/(N*m)",
                              motor.emf_peak_v_s_per_rad * lsb / math.sqrt(2.0) / mean_abs))
    else:
        notes.append("no DAQ current resolution in the capture meta (daq_lsb): its row is omitted")
    if instruments is not None:
        notes.append("the torque transducer's accuracy class does not enter: torque estimated "
                     "from the currents")
    if revolutions < 2:
        notes.append("one revolution only: type A cannot be estimated, U is undefined (NaN)")
    combined = math.sqrt(sum(row.contribution_pu ** 2 for row in rows if row.combination == "rss"))
    linear = sum(row.contribution_pu for row in rows if row.combination == "linear")
    return UncertaintyBudget(rows=tuple(rows), coverage_factor=COVERAGE_FACTOR,
                             combined_standard_pu=combined,
                             expanded_pu=COVERAGE_FACTOR * combined + linear,
                             noise_bias_pu=scatter.bias_pu, revolutions=revolutions,
                             bootstrap_draws=scatter.draws, notes=tuple(notes))


def _mechanical_angle(capture: Capture) -> np.ndarray:
    if "rotor_angle_mech_rad" in capture:
        return np.unwrap(check_finite("rotor_angle_mech_rad", capture["rotor_angle_mech_rad"]),
                         period=TWO_PI)
    if "encoder_counts" in capture:
        counts_per_rev = capture.meta.get("encoder_counts_per_rev")
        if not isinstance(counts_per_rev, (int, float)) or not counts_per_rev > 0:
            raise InputError("capture channel 'encoder_counts' needs meta 'encoder_counts_per_rev' "
                             f"> 0, got {counts_per_rev!r}")
        return check_finite("encoder_counts", capture["encoder_counts"]) * (TWO_PI / counts_per_rev)
    raise InputError("switching analysis needs the rotor angle: channel 'rotor_angle_mech_rad' or "
                     f"'encoder_counts'; the capture has {sorted(capture.channels)}")


def _pole_pairs(capture: Capture, motor: MotorParameters) -> int:
    value = capture.meta.get("pole_pairs", motor.pole_pairs)
    if isinstance(value, float) and value.is_integer():
        value = int(value)
    if not isinstance(value, (int, np.integer)) or isinstance(value, bool) or not 1 <= value <= 100:
        raise InputError(f"capture meta 'pole_pairs' must be an integer 1..100, got {value!r}")
    if value != motor.pole_pairs:
        raise InputError(f"capture meta pole_pairs={value} differs from the motor's "
                         f"{motor.pole_pairs} (pole_count={motor.pole_count})")
    return int(value)
