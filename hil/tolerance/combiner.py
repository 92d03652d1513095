"""Closed-form ripple of many drives at once: the sources' torque *waveforms* added by their
phases over one electrical revolution, vectorised over drives (numpy, no loop over drives).

Torque per unit of the ideal mean T0 = (3/2)·E·I·cos φ/ω_m (eq 7), at electrical angle θ:

    τ(θ) = [1 + r_off(θ) + r_gain(θ) + r_dt(θ)] · c_enc(θ)

* r_off — sensor dc offsets, eq 19 (``hil.model.dc_offset.ripple_pu``, linear in the offsets:
  the unit waveforms of each sensor are scaled by its offset per unit of I), order 1.
* r_gain — sensor gain errors, eqs 21-25 generalised to φ (``hil.model.gain_mismatch``,
  exact ratio form): the mean shift and (√3/2)(k1 − k2)·sin(2θ − φ − 2π/3), order 2.
* r_dt — dead time, the average-voltage model with the drive's PI current loop
  (``hil.model.dead_time.average_model_torque_pu``; bandwidth 0.08·f_pwm and 1.5 PWM periods of
  delay, as ``hil.sim.FirmwareModel``): affine in T_d, so one unit waveform per PWM frequency,
  scaled by T_d. The paper's eq 38 is a per-event step with no waveform (4× the closed-loop
  ripple, hil/model/README.md), so it cannot be combined by phase.
* c_enc — encoder staircase cos(γ + φ)/cos φ, eqs 7-9, γ = θ − θ_d the angle since the last count
  (for counts of order ≤ ``max_order`` the product is replaced by the torque sum of eq 7 itself,
  see ``_coarse_encoder_ripple``: there the offset × staircase term is not small).

The ripple is measured as the twin engine and the bench measure it: pk-pk over the revolution of
τ band-limited to electrical orders 1..``max_order`` (design.md §3), per unit of its mean. So an
encoder whose count order 2π/θ_res exceeds ``max_order`` (7200 counts: order 3600) contributes
only its mean (the paper's eq 9 ripple is outside the band); coarser encoders (Hall 60°,
large decimation) are computed row by row on a fine grid and band-limited through an FFT.

Combination is first order: products of two sources' errors (offset × gain error, ~1e-4) are
dropped, as the paper's per-source derivations drop their own second-order terms — except with a
coarse encoder, whose rows take the exact torque sum.

Sources with a bound and no waveform (word length, eq 14: 10/2^(n−1)·I_max/(I·cos φ); PWM
resolution, the closed-loop bound of ``hil.model.pwm_resolution``) cannot be phased; with
``bounds=True`` their pk-pk is added to the combined pk-pk (conservative), else left out.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from hil.model import dc_offset, gain_mismatch
from hil.model.core import PHASE_OFFSETS_RAD, OperatingPoint
from hil.model.dead_time import average_model_torque_pu
from hil.model.pwm_resolution import closed_loop_bound_pu, voltage_phasor
from hil.model.word_length import FULL_SCALE_CURRENT_A, paper_pk_pk_pu

#: The simulated drive's loop (hil.sim.FirmwareModel): bandwidth per PWM frequency, delay in periods.
LOOP_BANDWIDTH_PER_PWM = 0.08
LOOP_DELAY_PWM_PERIODS = 1.5
UNIT_DEAD_TIME_S = 1e-6
GRID_POINTS = 256
FINE_GRID_POINTS = 4096


@dataclass(frozen=True)
class CombinerSettings:
    max_order: int = 64
    bounds: bool = True


def grid(points: int = GRID_POINTS) -> np.ndarray:
    return np.linspace(0.0, 2.0 * math.pi, points, endpoint=False)


def band_limit(rows: np.ndarray, max_order: int, points: int) -> np.ndarray:
    """Rows of samples over one revolution → their Fourier series to ``max_order`` on ``points``."""
    spectrum = np.fft.rfft(rows, axis=-1)
    spectrum[..., max_order + 1:] = 0.0
    return np.fft.irfft(spectrum, n=rows.shape[-1], axis=-1)[..., ::rows.shape[-1] // points]


def resample_periodic(rows: np.ndarray, points: int) -> np.ndarray:
    """Band-limited rows over one revolution → the same Fourier series on ``points`` samples."""
    spectrum = np.fft.rfft(rows, axis=-1)
    padded = np.zeros(rows.shape[:-1] + (points // 2 + 1,), dtype=complex)
    padded[..., :spectrum.shape[-1]] = spectrum
    return np.fft.irfft(padded, n=points, axis=-1) * (points / rows.shape[-1])


@lru_cache(maxsize=64)
def dead_time_unit_waveform(op: OperatingPoint, pwm_frequency_hz: float, max_order: int,
                            points: int = GRID_POINTS) -> np.ndarray:
    """τ − 1 for T_d = 1 µs (average-voltage model, drive's loop), band-limited, per µs."""
    fine = grid(FINE_GRID_POINTS)
    torque = average_model_torque_pu(fine, op, UNIT_DEAD_TIME_S, pwm_frequency_hz,
                                     LOOP_BANDWIDTH_PER_PWM * pwm_frequency_hz,
                                     LOOP_DELAY_PWM_PERIODS / pwm_frequency_hz)
    return band_limit((torque - 1.0)[None, :], max_order, points)[0]


def _column(params: dict[str, np.ndarray], name: str, n: int, default: float) -> np.ndarray:
    value = params.get(name)
    return np.full(n, default, dtype=float) if value is None else np.asarray(value, dtype=float)


def encoder_resolution_rad(params: dict[str, np.ndarray], n: int, pole_pairs: int) -> np.ndarray:
    """θ_res per drive, electrical rad: 2π·p·decimation/counts, or 60° with Hall sensors."""
    counts = _column(params, "encoder_counts_per_rev", n, 7200)
    decimation = _column(params, "encoder_decimation", n, 1)
    hall = _column(params, "hall_mode", n, 0) > 0.5
    return np.where(hall, math.pi / 3.0, 2.0 * math.pi * pole_pairs * decimation / counts)


def bound_terms_pu(op: OperatingPoint, params: dict[str, np.ndarray], n: int) -> np.ndarray:
    """Word-length (eq 14) plus PWM-resolution (closed-loop) pk-pk bounds, per unit of T0."""
    bits = _column(params, "word_length_bits", n, 0)
    scale = FULL_SCALE_CURRENT_A / (op.current_a * math.cos(op.current_angle_rad))
    word = np.where(bits > 0, paper_pk_pk_pu(16) * 2.0 ** (16 - np.maximum(bits, 6)) * scale, 0.0)
    counts = _column(params, "pwm_period_counts", n, 2000)
    f_pwm = _column(params, "pwm_frequency_hz", n, 20000.0)
    pwm = np.empty(n)
    for freq in np.unique(f_pwm):  # the bound is linear in 1/C at a given loop bandwidth
        rows = f_pwm == freq
        pwm[rows] = closed_loop_bound_pu(op, 1.0, LOOP_BANDWIDTH_PER_PWM * freq) / counts[rows]
    return word + pwm


def linear_range_warning(op: OperatingPoint) -> str | None:
    """A warning when the point needs more phase voltage than SVPWM gives (V_dc/√3 peak): the
    current is then not regulated and every closed form here (ideal regulation) is void."""
    needed_v = math.sqrt(2.0) * abs(voltage_phasor(op))
    available_v = op.dc_bus_v / math.sqrt(3.0)
    if needed_v <= available_v:
        return None
    return (f"{op.speed_rpm:g} rpm, {op.current_a:g} A: needs {needed_v:.2f} V peak phase "
            f"voltage, beyond SVPWM's {available_v:.2f} V at {op.dc_bus_v:g} V dc: the current "
            "is not regulated there and the closed form does not apply")


def ripple_pu(op: OperatingPoint, params: dict[str, np.ndarray], n: int,
              settings: CombinerSettings = CombinerSettings()) -> np.ndarray:
    """Pk-pk ripple per unit of the mean torque of ``n`` drives at ``op`` (module docstring).

    ``params`` maps parameter names (``hil.tolerance.spec.PARAMETERS``) to arrays of ``n``
    values; a missing parameter takes the drive's nominal value.
    """
    phi = op.current_angle_rad
    cos_phi = math.cos(phi)
    theta = grid()
    current = op.current_a
    # eq 19: linear in the offsets per unit of I -> unit waveform of each sensor
    w_a = dc_offset.ripple_pu(theta, 1.0, 0.0, phi)
    w_b = dc_offset.ripple_pu(theta, 0.0, 1.0, phi)
    # eqs 21-25: mean and order-2 amplitude in units of E·I/ω_m
    k1, k2 = gain_mismatch.current_errors(_column(params, "ia_gain_error_pu", n, 0.0),
                                          _column(params, "ib_gain_error_pu", n, 0.0))
    mean_gain, amp_gain = gain_mismatch.torque_coefficients(k1, k2, phi)
    ideal = 1.5 * cos_phi
    columns = [_column(params, "ia_offset_a", n, 0.0) / current,
               _column(params, "ib_offset_a", n, 0.0) / current,
               np.asarray(amp_gain) / ideal * np.ones(n)]
    basis = [w_a, w_b, np.sin(2.0 * theta - phi - 2.0 * math.pi / 3.0)]
    dead = _column(params, "dead_time_s", n, 0.0)
    f_pwm = _column(params, "pwm_frequency_hz", n, 20000.0)
    for freq in np.unique(f_pwm):
        columns.append(np.where(f_pwm == freq, dead / UNIT_DEAD_TIME_S, 0.0))
        basis.append(dead_time_unit_waveform(op, float(freq), settings.max_order))
    # float32: 3x faster here, and its rounding (~1e-7 of a torque near 1) is ~1e-5 of a ripple
    shift = (1.0 + (np.asarray(mean_gain) - ideal) / ideal * np.ones(n)).astype(np.float32)
    slow = np.stack(columns, axis=1).astype(np.float32) @ np.stack(basis, axis=0).astype(np.float32)
    slow += shift[:, None]
    mean = slow.mean(axis=1, dtype=np.float64)
    ripple = np.ptp(slow, axis=1).astype(np.float64) / mean

    resolution = encoder_resolution_rad(params, n, op.motor.pole_pairs)
    coarse = np.flatnonzero(2.0 * math.pi / resolution <= settings.max_order + 1e-9)
    if coarse.size:
        dead_rows = (np.stack(columns[3:], axis=1)[coarse] @ np.stack(basis[3:], axis=0))
        ripple[coarse], mean[coarse] = _coarse_encoder_ripple(
            op, {k: np.asarray(v)[coarse] for k, v in params.items()}, resolution[coarse],
            dead_rows, settings.max_order)
    if settings.bounds:
        ripple += bound_terms_pu(op, params, n) / mean
    return ripple


def _coarse_encoder_ripple(op: OperatingPoint, params: dict[str, np.ndarray],
                           resolution: np.ndarray, dead_time_pu: np.ndarray,
                           max_order: int) -> tuple[np.ndarray, np.ndarray]:
    """Counts of order ≤ max_order (Hall, large decimation): the torque sum of eq 7 itself,
    Σ e_x·i_x/ω_m with the currents regulated to the truncated angle θ_d (eqs 4, 7) and the
    sensors' offsets and gains undone (eqs 15-17, 21-22): i_a = (I·sin(θ_d − φ) − offset_a)/(1 + g_a),
    likewise b, i_c = −i_a − i_b — exact, since here the offset × staircase cross term is as
    large as the offset's own ripple; the dead-time waveform (rows of ``dead_time_pu``, per unit
    of T0 on the coarse grid) is added. Band-limited: (pk-pk per unit of the mean, mean per unit
    of T0)."""
    phi = op.current_angle_rad
    theta = grid(FINE_GRID_POINTS)[None, :]
    res = resolution[:, None]
    theta_d = np.floor(theta / res + 1e-9) * res
    n = resolution.size
    col = lambda name, default: _column(params, name, n, default)[:, None]  # noqa: E731
    i_a = (np.sin(theta_d - phi) - col("ia_offset_a", 0.0) / op.current_a) \
        / (1.0 + col("ia_gain_error_pu", 0.0))
    i_b = (np.sin(theta_d - phi - 2.0 * math.pi / 3.0) - col("ib_offset_a", 0.0) / op.current_a) \
        / (1.0 + col("ib_gain_error_pu", 0.0))
    shapes = [np.sin(theta - offset) for offset in PHASE_OFFSETS_RAD]  # e_x / E
    torque = (shapes[0] * i_a + shapes[1] * i_b - shapes[2] * (i_a + i_b)) \
        / (1.5 * math.cos(phi))
    torque += resample_periodic(dead_time_pu, FINE_GRID_POINTS)
    limited = band_limit(torque, max_order, FINE_GRID_POINTS)
    mean = limited.mean(axis=1)
    return np.ptp(limited, axis=1) / mean, mean
