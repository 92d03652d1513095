"""Ripple metrics of a torque capture: the chain angle → revolutions → orders → figures → budget.

Definitions (the project's, design.md §3), all over the whole electrical revolutions used; the
spectrum figures cover electrical orders 1..``max_order`` (:mod:`hil.analysis.spectrum`):

* ``mean_torque_nm``: the angle-average torque, c₀.
* ``sync_average_nm``: the synchronous average — the mean over revolutions of the angle-binned
  torque — at the bin centres ``angle_grid_rad``, as the pk-pk sees it: its Fourier series up to
  ``max_order`` (``"band-limited"``) or the raw bin means (``"bins"``).
* ``pk_pk_nm``: peak-to-peak of the synchronous average, by ``pk_pk_method``:

  - ``"band-limited"`` (default): of its Fourier series up to ``max_order``, extremes searched on
    a fine grid. Exact for smooth ripple and least sensitive to noise; a *step* in the torque
    (encoder quantisation at standstill) rings by the Gibbs overshoot (≈ 9 % of the step at each
    side) and harmonics above ``max_order`` are cut.
  - ``"bins"``: max − min of the synchronous average's angle bins (width 2π/N, N ≥ 8·max_order).
    No overshoot on steps; a sinusoid of order k reads low by up to ``1 − cos(πk/N)·sinc(k/N)``
    and noise lifts it more (the budget's bias row says how much). Choose a large ``max_order``
    (fine bins) for step-shaped ripple.
* ``pk_pk_pu``: ``pk_pk_nm / |mean_torque_nm|`` — the per-unit torque ripple of the paper
  (e.g. eq 9) and the project (NaN when the mean torque is exactly zero).
* ``pk_pk_rated_pu``: ``pk_pk_nm / rated_torque_nm`` when a rated torque is given, else None.
* ``rms_ac_nm``: RMS of the AC part of the synchronous average, ``sqrt(Σ A_k²/2)``, k = 1..K.
* ``orders``/``amplitude_nm``/``phase_rad``: the order spectrum, ``τ = c₀ + Σ A_k cos(kθ + φ_k)``
  (single-sided, amplitude-correct, θ = electrical angle).
* ``dominant_order``: the order with the largest amplitude; ``order_power_share(k)``: A_k² / Σ A_j².
* ``named_order``/``named_amplitude_nm``/``named_phase_rad``: the order a prediction names.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from hil.analysis.angle import TWO_PI, angle_from_speed, check_finite, check_time, travel_angle
from hil.analysis.resample import (interpolation_response, resample_revolutions,
                                   samples_per_revolution)
from hil.analysis.spectrum import order_coefficients, peak_to_peak, reconstruct
from hil.analysis.uncertainty import (InstrumentUncertainty, UncertaintyBudget,
                                      amplitude_standard_uncertainty, build_budget, type_a)
from hil.capture import Capture
from hil.errors import InputError

DEFAULT_MAX_ORDER = 64
MIN_SAMPLES = 16
#: How the pk-pk of the synchronous average is taken (module docstring).
PK_PK_METHODS = ("band-limited", "bins")


@dataclass(frozen=True)
class RippleResult:
    """Figures of one capture (definitions in the module docstring)."""

    mean_torque_nm: float
    pk_pk_nm: float
    pk_pk_pu: float
    pk_pk_rated_pu: float | None
    rated_torque_nm: float | None
    rms_ac_nm: float
    orders: np.ndarray
    amplitude_nm: np.ndarray
    phase_rad: np.ndarray
    amplitude_u_nm: np.ndarray          # type-A standard uncertainty of each A_k
    dominant_order: int
    pk_pk_method: str
    named_order: int | None
    named_amplitude_nm: float | None
    named_phase_rad: float | None
    revolutions: int
    samples_per_rev: int
    max_order: int
    direction: int                      # +1 electrical angle increasing, -1 decreasing
    angle_grid_rad: np.ndarray
    sync_average_nm: np.ndarray
    revolution_matrix_nm: np.ndarray = field(repr=False)
    uncertainty: UncertaintyBudget | None = field(repr=False)  # None: not computed (analyze_torque)

    def order_power_share(self, order: int) -> float:
        """Share of the AC power (orders 1..max_order) carried by ``order``: A_k² / Σ A_j²."""
        if not 1 <= order <= self.max_order:
            raise InputError(f"order {order!r} is outside the analysed band 1..{self.max_order}")
        power = self.amplitude_nm ** 2
        total = float(power.sum())
        return float(power[order - 1] / total) if total > 0 else 0.0

    def top_orders(self, count: int = 5) -> list[dict]:
        """The ``count`` largest orders: order, amplitude_nm, phase_rad, share of AC power."""
        ranked = np.argsort(self.amplitude_nm)[::-1][:count]
        return [{"order": int(self.orders[i]), "amplitude_nm": float(self.amplitude_nm[i]),
                 "amplitude_u_nm": float(self.amplitude_u_nm[i]),
                 "phase_rad": float(self.phase_rad[i]),
                 "power_share": self.order_power_share(int(self.orders[i]))} for i in ranked]

    def to_dict(self, *, arrays: bool = False, top: int = 5) -> dict:
        """JSON-ready figures (NaN becomes None); the spectrum and big arrays only with
        ``arrays=True``."""
        data = {
            "mean_torque_nm": self.mean_torque_nm, "pk_pk_nm": self.pk_pk_nm,
            "pk_pk_pu": _json_float(self.pk_pk_pu), "pk_pk_rated_pu": self.pk_pk_rated_pu,
            "rated_torque_nm": self.rated_torque_nm, "rms_ac_nm": self.rms_ac_nm,
            "dominant_order": self.dominant_order, "pk_pk_method": self.pk_pk_method,
            "named_order": self.named_order,
            "named_amplitude_nm": self.named_amplitude_nm,
            "named_phase_rad": self.named_phase_rad, "revolutions": self.revolutions,
            "samples_per_rev": self.samples_per_rev, "max_order": self.max_order,
            "direction": self.direction, "top_orders": self.top_orders(top),
            "uncertainty": None if self.uncertainty is None else self.uncertainty.to_dict(),
        }
        if arrays:
            data.update(orders=self.orders.tolist(), amplitude_nm=self.amplitude_nm.tolist(),
                        phase_rad=self.phase_rad.tolist(),
                        amplitude_u_nm=self.amplitude_u_nm.tolist(),
                        angle_grid_rad=self.angle_grid_rad.tolist(),
                        sync_average_nm=self.sync_average_nm.tolist(),
                        revolution_matrix_nm=self.revolution_matrix_nm.tolist())
        return _json_clean(data)


def _json_float(value: float | None) -> float | None:
    return None if value is None or not math.isfinite(value) else float(value)


def _json_clean(value):
    if isinstance(value, float):
        return _json_float(value)
    if isinstance(value, dict):
        return {key: _json_clean(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_clean(item) for item in value]
    return value


def spectrum_fields(amplitude: np.ndarray, phase: np.ndarray, per_rev: np.ndarray,
                    named_order: int | None) -> dict:
    """The :class:`RippleResult` fields that follow from an order spectrum (orders 1..len):
    RMS of the AC part, amplitudes, phases and their standard uncertainty from the
    revolution-to-revolution coefficients ``per_rev``, the dominant and the named order."""
    return {"rms_ac_nm": float(np.sqrt(np.sum(amplitude ** 2) / 2.0)),
            "orders": np.arange(1, len(amplitude) + 1), "amplitude_nm": amplitude,
            "phase_rad": phase,
            "amplitude_u_nm": amplitude_standard_uncertainty(per_rev)[1:],
            "dominant_order": int(np.argmax(amplitude)) + 1, "named_order": named_order,
            "named_amplitude_nm": None if named_order is None else float(amplitude[named_order - 1]),
            "named_phase_rad": None if named_order is None else float(phase[named_order - 1])}


def analyze_torque(time_s, torque_nm, angle_elec_rad, *, max_order: int = DEFAULT_MAX_ORDER,
                   named_order: int | None = None, rated_torque_nm: float | None = None,
                   instruments: InstrumentUncertainty | None = None,
                   pk_pk_method: str = "band-limited",
                   uncertainty_budget: bool = True) -> RippleResult:
    """Analyse torque samples against the electrical rotor angle (wrapped or unwrapped, rad).

    ``uncertainty_budget=False`` skips the bootstrap (type A) and the budget, for callers that
    need the ripple figures only (Monte Carlo campaigns of the twin): every other field is the
    same, bit for bit, and ``uncertainty`` is None (such a result cannot be judged by
    :func:`hil.analysis.decide`).

    Raises InputError for non-finite samples, non-increasing time, mismatched lengths, an angle
    that never advances or runs backwards, a record shorter than one electrical revolution, or
    out-of-range options.
    """
    time_s = check_time(time_s)
    torque_nm = check_finite("torque_nm", torque_nm)
    angle_elec_rad = np.asarray(angle_elec_rad, dtype=np.float64)
    if not time_s.size == torque_nm.size == angle_elec_rad.size:
        raise InputError(f"time ({time_s.size}), torque ({torque_nm.size}) and angle "
                         f"({angle_elec_rad.size}) must have the same number of samples")
    if time_s.size < MIN_SAMPLES:
        raise InputError(f"the capture has {time_s.size} samples; at least {MIN_SAMPLES} needed")
    max_order = _check_order("max_order", max_order, 4096)
    if named_order is not None:
        named_order = _check_order("named_order", named_order, max_order)
    if rated_torque_nm is not None and not (math.isfinite(rated_torque_nm) and rated_torque_nm > 0):
        raise InputError(f"rated_torque_nm must be a positive number, got {rated_torque_nm!r}")
    if pk_pk_method not in PK_PK_METHODS:
        raise InputError(f"pk_pk_method must be one of {PK_PK_METHODS}, got {pk_pk_method!r}")

    travel = travel_angle(time_s, angle_elec_rad)
    revs = resample_revolutions(travel, torque_nm, samples_per_revolution(max_order))
    per_rev = order_coefficients(revs.matrix_nm, max_order,
                                 interpolation_response(travel.travel_rad, max_order))
    coefficients = per_rev.mean(axis=0)
    mean = float(coefficients[0].real)
    amplitude = np.abs(coefficients[1:])
    phase = np.angle(coefficients[1:])
    if pk_pk_method == "band-limited":
        per_rev_rows, statistic = per_rev, _band_limited_pk_pk_pu
        sync_average = reconstruct(coefficients, revs.samples_per_rev, centred=True)
        pk_pk = float(peak_to_peak(coefficients[None, :])[0])
    else:
        per_rev_rows, statistic = revs.matrix_nm, _bins_pk_pk_pu
        sync_average = revs.matrix_nm.mean(axis=0)
        pk_pk = float(np.ptp(sync_average))
    pk_pk_pu = pk_pk / abs(mean) if mean != 0 else math.nan
    budget = None
    if uncertainty_budget:
        scatter = type_a(per_rev_rows, statistic)
        budget = build_budget(pk_pk_pu=pk_pk_pu, pk_pk_nm=pk_pk, mean_torque_nm=mean,
                              type_a_result=scatter, revolutions=revs.revolutions,
                              instruments=instruments)
    return RippleResult(
        mean_torque_nm=mean, pk_pk_nm=pk_pk, pk_pk_pu=pk_pk_pu,
        pk_pk_rated_pu=None if rated_torque_nm is None else pk_pk / rated_torque_nm,
        rated_torque_nm=rated_torque_nm,
        **spectrum_fields(amplitude, phase, per_rev, named_order), pk_pk_method=pk_pk_method,
        revolutions=revs.revolutions, samples_per_rev=revs.samples_per_rev, max_order=max_order,
        direction=travel.direction, angle_grid_rad=revs.angle_grid_rad,
        sync_average_nm=sync_average,
        revolution_matrix_nm=revs.matrix_nm, uncertainty=budget)


def analyze_capture(capture: Capture, *, max_order: int = DEFAULT_MAX_ORDER,
                    named_order: int | None = None, rated_torque_nm: float | None = None,
                    instruments: InstrumentUncertainty | None = None,
                    pole_pairs: int | None = None,
                    pk_pk_method: str = "band-limited",
                    period_revolutions: int = 1) -> RippleResult:
    """Analyse a :class:`~hil.capture.Capture` (channels ``time_s``, ``torque_nm`` and an angle).

    The mechanical angle comes from ``rotor_angle_mech_rad`` (wrapped or unwrapped), else from
    ``encoder_counts`` with meta ``encoder_counts_per_rev``, else by integrating ``speed_rpm``
    (then phases refer to the first sample, not to the rotor's electrical zero). Electrical angle
    = ``pole_pairs`` (argument, else meta ``pole_pairs``) × mechanical angle.

    ``period_revolutions`` m > 1 analyses over a period of m electrical revolutions: the
    "revolutions" are periods and order k is k/m of the electrical frequency (a ripple that
    repeats only every m electrical revolutions, e.g. an encoder count order of 57.6 per
    electrical revolution: 288 over 5, ``hil.model.encoder.count_period``).
    """
    pole_pairs = _pole_pairs(capture, pole_pairs)
    period = _check_order("period_revolutions", period_revolutions, 10_000)
    time_s = check_time(capture["time_s"])
    if "rotor_angle_mech_rad" in capture:
        mech = check_finite("rotor_angle_mech_rad", capture["rotor_angle_mech_rad"])
        mech = np.unwrap(mech, period=TWO_PI)
    elif "encoder_counts" in capture:
        counts_per_rev = capture.meta.get("encoder_counts_per_rev")
        if not isinstance(counts_per_rev, (int, float)) or not counts_per_rev > 0:
            raise InputError("capture channel 'encoder_counts' needs meta 'encoder_counts_per_rev' "
                             f"> 0, got {counts_per_rev!r}")
        mech = check_finite("encoder_counts", capture["encoder_counts"]) * (TWO_PI / counts_per_rev)
    elif "speed_rpm" in capture:
        mech = angle_from_speed(time_s, capture["speed_rpm"])
    else:
        raise InputError("capture has no rotor angle: it needs channel 'rotor_angle_mech_rad', "
                         f"'encoder_counts' or 'speed_rpm'; it has {sorted(capture.channels)}")
    return analyze_torque(time_s, capture["torque_nm"], pole_pairs * mech / period,
                          max_order=max_order,
                          named_order=named_order, rated_torque_nm=rated_torque_nm,
                          instruments=instruments, pk_pk_method=pk_pk_method)


def _band_limited_pk_pk_pu(coefficients: np.ndarray) -> np.ndarray:
    """pk-pk per unit of |mean| of the Fourier series in each row (c_0..c_K): the type-A
    bootstrap's statistic, its waveform in single precision (:func:`peak_to_peak`)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return (peak_to_peak(coefficients, single_precision=True)
                / np.abs(coefficients[:, 0].real))


def _bins_pk_pk_pu(bins_nm: np.ndarray) -> np.ndarray:
    """max − min per unit of |mean| of the angle bins in each row."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.ptp(bins_nm, axis=-1) / np.abs(bins_nm.mean(axis=-1))


def _pole_pairs(capture: Capture, override: int | None) -> int:
    value = override if override is not None else capture.meta.get("pole_pairs")
    if isinstance(value, float) and value.is_integer():
        value = int(value)
    if not isinstance(value, int) or isinstance(value, bool) or not 1 <= value <= 100:
        raise InputError(f"capture meta 'pole_pairs' must be an integer 1..100, got {value!r}")
    return value


def _check_order(name: str, value, upper: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) \
            or not 1 <= value <= upper:
        raise InputError(f"{name} must be an integer in 1..{upper}, got {value!r}")
    return int(value)
