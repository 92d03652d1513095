"""Duty-quantisation noise through the digital current loop: the torque ripple that is *not*
synchronous with the rotor (not in the paper; paper section III-D, eqs 27-28, gives the
open-loop voltage step this starts from).

The derived pk-pk form (``hil.model.pwm_resolution``, ``model="derived"``) follows the
synchronous pattern of the truncated duties and assumes the loop's reaction does not move the
quantisation steps. Under a closed loop it does: the loop reacts to each period's duty error,
which moves the next references across count boundaries, so most of the ripple does not
repeat from one revolution to the next. This form predicts the RMS of that part, the statistic
of :mod:`hil.analysis.nonsync` (torque minus its synchronous average over R revolutions, orders
0..``max_order``), per unit of the nameplate mean torque K_t·I·cos φ.

The sampled loop (``loop_matrices``), stated by the bench file's ``[drive]`` and assumed here:
the PI of the continuous design (Kp = ω_c·L, Ki = ω_c·R) runs once per PWM period, integrator
first (v_k = Kp·ε_k + Ki·T·Σ_{j≤k} ε_j), on a current sampled ``delay_s``·f_pwm − ½ periods
before the period its output is applied in (0, ½, 1 or 1½; the PWM's average voltage adds the
½), in the rotor frame without decoupling; the period-average leg voltages drive the exact R-L
plant with its cross-coupling ω_e·L (the switching pattern inside a period, dead time and the
ADC are neglected); the torque follows i_q (non-salient motor); the transducer is a first-order
low-pass of ``transducer_bandwidth_hz``. State per period k (deviations from the steady state):
x = [i(t_k), y(t_k), i(t_k − T/2), integrator, command of period k], y the low-passed current.

Two evaluations of the duty error n_k (the space vector of the three legs' truncation errors):

* ``white_noise_rms_pu``: n_k as additive white noise — each leg's error uniform over one count
  of V_dc/C, independent between legs and periods, E|n|² = (4/3)·(V_dc/C)²/12; the stationary
  covariance from the discrete Lyapunov equation P = A·P·Aᴴ + B·q·Bᴴ. Recorded for comparison:
  the simulated drive lies at 1.05-2.0× it (median 1.5; the loop moves the references by a
  fraction of a count per period, so the error runs in stretches of one sign and sits near the
  ends of the count more often than a uniform error would: in the quantised loop at 500 rpm,
  20 A its variance is ~1.4× (V_dc/C)²/12 and its spectrum leans to low frequencies, which the
  transducer passes).
* ``quantised_loop_torque_pu`` (the expectation): the same loop with the truncation itself in
  it. Each period the steady-state leg references (the phasor V∠δ of eq 27's circuit, SVPWM
  min-max or sine) plus the loop's command deviation are truncated to whole counts, floor((½ +
  v_x/V_dc)·C), and the error's space vector drives the next state. Deterministic; where the
  references fall on the count grid is not known to a fraction of a count, so it runs
  ``trials`` leg offsets spread over one count (``hil.model.pwm_resolution.grid_offsets``), each
  over the capture's R revolutions after a settling time, and the statistic's mean square over
  the trials is the expectation (a quadratic mean).
Both scale as 1/C only where the truncation is busy; at small C the quantised loop is not
monotonic in C (nor is the simulated drive).

Expected range. A drive is *one* of the trials, not their mean: which count boundaries its
references cross, and when, is fixed by fractions of a count the model cannot know (the loop's
steady error, the ADC, the fixed-point sin/cos move the references by a good part of a count at
small C: V_dc/C = 1.5 V at 48 V and C = 32). Where few boundaries are crossed (small C, low
voltage, low speed) the deterministic pattern of the truncation then differs from trial to trial
(8-pole 48 V motor at −250 rpm, 10 A, C = 32: 0.46-0.90 % over 16 trials, quadratic mean
0.58 %; the simulated drive 0.87 %), and the range around the mean failed correct drives by up to
+50 %. So the range is [low·min, high·max] over the trials (``NOISE_RANGE_FACTORS``); where the
truncation is busy the trials agree within a few % and the range stays about ±15 % of the value
(Table I 500 rpm, 20 A, C = 128: 0.146-0.156 %), which is what catches a counter applied scaled.
"""

from __future__ import annotations

import cmath
import math
from dataclasses import dataclass

import numpy as np
from numba import njit
from scipy.linalg import expm, solve_discrete_lyapunov

from hil.analysis.nonsync import synchronous_residual
from hil.errors import InputError
from hil.model.core import OperatingPoint, check_range
from hil.model.pwm_resolution import MODULATIONS, grid_offsets

#: Computation delays (PWM periods) the sampled loop model represents: sampled at the counter
#: valley (0, 1) or peak (½, 1½) before the period the output is applied in.
COMPUTATION_DELAYS = (0.0, 0.5, 1.0, 1.5)
#: Leg offsets (fractions of a count) the quantised loop is run with (module docstring): 16, so
#: that their extremes, which bound the expected range, are sampled densely enough.
NOISE_TRIALS = 16
#: Settling time of the quantised loop before its revolutions are kept, s (≫ 1/ω_c).
SETTLE_S = 0.01
#: Expected range of one drive's statistic, (low, high) factors applied to the smallest and the
#: largest of the trials' values (module docstring, "Expected range"). Calibration set (Table I,
#: 250-1500 rpm, 10-40 A, C = 22-256, R = 8: 66 points, ``studies/pwm_noise_vs_twin.py``): the
#: simulated drive lay at 0.90-1.13× of those ends (at 0.75-1.23× the trials' quadratic mean,
#: which was the range's centre before). Rounded outward to [0.85, 1.15]; holdout (other motors,
#: points and seeds): hil/model/README.md.
NOISE_RANGE_FACTORS = (0.85, 1.15)

# state vector of the loop model, per PWM period k (complex, rotor frame, deviations)
_I, _Y, _MID, _INT, _U = range(5)


@dataclass(frozen=True)
class NoisePrediction:
    """Non-synchronous torque RMS per unit of the mean torque K_t·I·cos φ (module docstring)."""

    rms_pu: float                   # the quantised loop's statistic: the expectation
    expected_range_pu: tuple[float, float]
    white_noise_rms_pu: float       # additive white-noise form of the same statistic
    trials_rms_pu: tuple[float, ...]
    counts: float
    computation_delay_periods: float
    assumptions: tuple[str, ...]

    def to_dict(self) -> dict:
        return {"rms_pu": self.rms_pu, "expected_range_pu": list(self.expected_range_pu),
                "white_noise_rms_pu": self.white_noise_rms_pu,
                "trials_rms_pu": list(self.trials_rms_pu), "counts": self.counts,
                "computation_delay_periods": self.computation_delay_periods,
                "assumptions": list(self.assumptions)}


def steady_phasor_peak_v(op: OperatingPoint) -> complex:
    """Peak phase-voltage phasor of the steady state, angle from the q axis (the EMF's direction
    in forward rotation): V = sign(ω)·E + (R + j·ω_e·L)·I·e^(−jφ) with the signed speed (eq 27's
    circuit). In reverse rotation the drive still commands +I on q, so it brakes: −E + (R −
    j·|ω_e|·L)·I, not the motoring phasor of ``OperatingPoint.voltage_phasor_peak_v``."""
    motor = op.motor
    current = op.current_a * cmath.exp(-1j * op.current_angle_rad)
    impedance = complex(motor.phase_resistance_ohm, op.elec_speed_rad_s * motor.phase_inductance_h)
    return math.copysign(op.emf_peak_v, op.speed_rpm) + impedance * current


def computation_delay_periods(delay_s: float, pwm_frequency_hz: float) -> float:
    """The loop's computation delay in PWM periods: total delay − ½ (the PWM average)."""
    periods = delay_s * pwm_frequency_hz - 0.5
    for allowed in COMPUTATION_DELAYS:
        if math.isclose(periods, allowed, abs_tol=1e-6):
            return allowed
    raise InputError(f"current_loop_delay_s={delay_s:g} s is {periods + 0.5:g} PWM periods at "
                     f"{pwm_frequency_hz:g} Hz; the sampled-loop noise model needs 0.5, 1, 1.5 "
                     f"or 2 periods (a computation delay of 0, ½, 1 or 1½ plus the PWM's ½)")


def loop_matrices(op: OperatingPoint, pwm_frequency_hz: float, bandwidth_hz: float,
                  delay_periods: float, transducer_bandwidth_hz: float):
    """(A, B): x_{k+1} = A·x_k + B·n_k of the sampled loop (module docstring), n_k the period's
    voltage error space vector (V, rotor frame)."""
    motor = op.motor
    period = 1.0 / pwm_frequency_hz
    r, ind = motor.phase_resistance_ohm, motor.phase_inductance_h
    z = (r + 1j * op.elec_speed_rad_s * ind) / ind          # plant pole (rotor frame), 1/s
    w_t = 2.0 * math.pi * transducer_bandwidth_hz
    omega_c = 2.0 * math.pi * bandwidth_hz
    tuned = op.loop_motor                  # the gains' R and L (the plant's by default)
    kp, ki_t = omega_c * tuned.phase_inductance_h, omega_c * tuned.phase_resistance_ohm * period
    # d/dt [i, y, u] = [[-z, 0, 1/L], [w_t, -w_t, 0], [0, 0, 0]]·[i, y, u], u held
    generator = np.array([[-z, 0.0, 1.0 / ind], [w_t, -w_t, 0.0], [0.0, 0.0, 0.0]],
                         dtype=complex)
    full, half = expm(generator * period), expm(generator * period / 2.0)
    a = np.zeros((5, 5), dtype=complex)
    b = np.zeros(5, dtype=complex)
    # over period k the applied voltage is the command u_k plus the error n_k
    a[_I, _I], a[_I, _U], b[_I] = full[0, 0], full[0, 2], full[0, 2]
    a[_Y, _I], a[_Y, _Y], a[_Y, _U], b[_Y] = full[1, 0], full[1, 1], full[1, 2], full[1, 2]
    a[_MID, _I], a[_MID, _U], b[_MID] = half[0, 0], half[0, 2], half[0, 2]
    # the sample the command of period k+1 is computed from, as rows over (x_k, n_k)
    eye = np.eye(5, dtype=complex)
    sample_a, sample_b = {0.0: (a[_I], b[_I]), 0.5: (a[_MID], b[_MID]),
                          1.0: (eye[_I], 0.0), 1.5: (eye[_MID], 0.0)}[delay_periods]
    # integrator first, then the output (the current reference is constant: error = −sample)
    a[_INT] = eye[_INT] - ki_t * sample_a
    b[_INT] = -ki_t * sample_b
    a[_U] = a[_INT] - kp * sample_a
    b[_U] = b[_INT] - kp * sample_b
    return a, b


def white_noise_rms_pu(op: OperatingPoint, counts: float, a: np.ndarray, b: np.ndarray,
                       revolutions: int, max_order: int, pwm_frequency_hz: float) -> float:
    """The statistic for additive white duty errors (module docstring): the stationary q-axis
    variance of y less the 1/R share of its spectrum at orders |k| ≤ max_order that the
    synchronous fit removes, per unit of K_t·I·cos φ."""
    variance_v2 = (4.0 / 3.0) * (op.dc_bus_v / counts) ** 2 / 12.0
    covariance = solve_discrete_lyapunov(a, variance_v2 * np.outer(b, b.conj()))
    stationary = 0.5 * float(covariance[_Y, _Y].real)      # q-axis share of E|y|²
    period = 1.0 / pwm_frequency_hz
    f_e = abs(op.elec_speed_rad_s) / (2.0 * math.pi)
    removed = 0.0
    for k in range(-max_order, max_order + 1):
        for sign in (1.0, -1.0):      # real part: ¼·(S(f) + S(−f)) of the complex state
            zf = np.exp(2j * math.pi * sign * k * f_e * period)
            gain = np.linalg.solve(zf * np.eye(len(a)) - a, b)[_Y]
            removed += 0.25 * abs(gain) ** 2 * variance_v2 * period * f_e / revolutions
    return math.sqrt(max(stationary - removed, 0.0)) / (op.current_a
                                                        * math.cos(op.current_angle_rad))


def quantised_loop_torque_pu(op: OperatingPoint, counts: float, a: np.ndarray, b: np.ndarray,
                             *, pwm_frequency_hz: float, modulation: str, revolutions: int,
                             trials: int = NOISE_TRIALS) -> tuple[np.ndarray, np.ndarray]:
    """(electrical angle per kept period, rad; torque deviation per unit of K_t·I·cos φ,
    trials × periods) of the loop with the truncation in it (module docstring)."""
    omega_e = op.elec_speed_rad_s
    period = 1.0 / pwm_frequency_hz
    settle = int(math.ceil(SETTLE_S / period))
    kept = int(math.ceil(revolutions * 2.0 * math.pi / abs(omega_e) / period)) + 2
    steady = steady_phasor_peak_v(op)       # peak phasor, angle from the q axis
    out = _quantised_loop(np.ascontiguousarray(a), np.ascontiguousarray(b), steady,
                          grid_offsets(trials) / counts, float(counts), op.dc_bus_v,
                          omega_e * period, settle, kept, modulation == "svpwm")
    angle = omega_e * (settle + np.arange(kept)) * period
    return angle, out / (op.current_a * math.cos(op.current_angle_rad))


@njit(cache=True)
def _quantised_loop(a, b, steady, offsets, counts, vdc, step_rad, settle, kept, svpwm):
    """The quantised loop's y (q axis) per trial and kept period; offsets per unit of V_dc.
    State indices as ``_I, _Y, _MID, _INT, _U`` (the command is state[4], y is state[1]).
    Written without per-period allocations or BLAS calls (a 5×5 product per PWM period: the
    loop is ~2.5× faster than with ``a @ state``; the trajectories agree to ~1e-14)."""
    trials = offsets.shape[0]
    size = a.shape[0]
    u0 = np.exp(1j * 0.0)
    u1 = np.exp(1j * (2.0 * np.pi / 3.0))
    u2 = np.exp(1j * (-2.0 * np.pi / 3.0))
    out = np.empty((trials, kept))
    state = np.zeros(size, dtype=np.complex128)
    following = np.zeros(size, dtype=np.complex128)
    for trial in range(trials):
        state[:] = 0.0
        for k in range(settle + kept):
            rotation = np.exp(1j * step_rad * k)
            vector = (steady + state[4]) * rotation       # stator frame, EMF along the real axis
            leg0 = (vector * np.conj(u0)).real / vdc + offsets[trial, 0]
            leg1 = (vector * np.conj(u1)).real / vdc + offsets[trial, 1]
            leg2 = (vector * np.conj(u2)).real / vdc + offsets[trial, 2]
            if svpwm:
                middle = 0.5 * (max(leg0, leg1, leg2) + min(leg0, leg1, leg2))
                leg0 -= middle
                leg1 -= middle
                leg2 -= middle
            error = (np.floor((0.5 + leg0) * counts) / counts - 0.5 - leg0) * u0
            error += (np.floor((0.5 + leg1) * counts) / counts - 0.5 - leg1) * u1
            error += (np.floor((0.5 + leg2) * counts) / counts - 0.5 - leg2) * u2
            error *= (2.0 / 3.0) * vdc * np.conj(rotation)
            for row in range(size):
                total = 0j
                for column in range(size):
                    total += a[row, column] * state[column]
                following[row] = total + b[row] * error
            state[:] = following
            if k >= settle:
                out[trial, k - settle] = state[1].real
    return out


def predict_noise(op: OperatingPoint, counts: float, *, pwm_frequency_hz: float,
                  current_loop_bandwidth_hz: float, current_loop_delay_s: float,
                  transducer_bandwidth_hz: float, revolutions: int, max_order: int,
                  modulation: str = "svpwm", trials: int = NOISE_TRIALS) -> NoisePrediction:
    """Expected non-synchronous torque RMS of the transducer reading over ``revolutions``,
    per unit of K_t·I·cos φ, for duty steps of 1/``counts`` (module docstring)."""
    counts = check_range("pwm_period_counts", counts, 8, 65535, unit=" counts")
    f_sw = check_range("pwm_frequency_hz", pwm_frequency_hz, 2000.0, 50000.0, unit=" Hz")
    bandwidth = check_range("current_loop_bandwidth_hz", current_loop_bandwidth_hz, 10.0,
                            0.25 * f_sw, unit=" Hz")
    f_t = check_range("transducer_bandwidth_hz", transducer_bandwidth_hz, 1.0, 1e6, unit=" Hz")
    revolutions = int(check_range("revolutions", revolutions, 2, 1000))
    max_order = int(check_range("max_order", max_order, 1, 1000))
    trials = int(check_range("trials", trials, 1, 64))
    if modulation not in MODULATIONS:
        raise InputError(f"modulation={modulation!r} is not one of {', '.join(MODULATIONS)}")
    if op.speed_rpm == 0.0:
        raise InputError("speed_rpm=0: the synchronous average needs a turning rotor "
                         "(allowed: speed_rpm != 0)")
    if not op.current_a * math.cos(op.current_angle_rad) > 0:
        raise InputError("the noise is stated per unit of K_t·I·cos φ; it needs I·cos φ > 0")
    v_peak = abs(steady_phasor_peak_v(op))
    linear_limit = op.dc_bus_v / (math.sqrt(3.0) if modulation == "svpwm" else 2.0)
    if v_peak > linear_limit:
        raise InputError(f"the operating point needs a {v_peak:.3g} V peak phase voltage, beyond "
                         f"the {modulation} linear range {linear_limit:.3g} V (allowed: lower "
                         "speed or current)")
    delay = computation_delay_periods(current_loop_delay_s, f_sw)
    a, b = loop_matrices(op, f_sw, bandwidth, delay, f_t)
    if np.max(np.abs(np.linalg.eigvals(a))) >= 1.0:
        raise InputError(f"the current loop ({bandwidth:g} Hz, {delay:g} period(s) of delay) is "
                         "unstable as sampled; the noise model needs a stable loop")
    angle, torque = quantised_loop_torque_pu(op, counts, a, b, pwm_frequency_hz=f_sw,
                                             modulation=modulation, revolutions=revolutions,
                                             trials=trials)
    travel = np.abs(angle - angle[0])
    whole = travel < revolutions * 2.0 * math.pi          # the statistic's whole revolutions
    residual, _ = synchronous_residual(travel[whole], torque[:, whole], max_order)
    per_trial = np.sqrt(np.mean(residual ** 2, axis=1))
    value = math.sqrt(float(np.mean(np.square(per_trial))))
    low, high = NOISE_RANGE_FACTORS
    return NoisePrediction(
        rms_pu=value, expected_range_pu=(low * float(per_trial.min()),
                                         high * float(per_trial.max())),
        white_noise_rms_pu=white_noise_rms_pu(op, counts, a, b, revolutions, max_order, f_sw),
        trials_rms_pu=tuple(float(v) for v in per_trial), counts=float(counts),
        computation_delay_periods=delay,
        assumptions=(
            f"compare values truncated to whole counts of 1/{counts:g} inside the loop "
            f"({modulation}, steady-state references of eq 27's phasor circuit), mean square "
            f"over {trials} leg offsets within a count",
            f"sampled PI loop Kp = ω_c·L, Ki = ω_c·R, ω_c = 2π·{bandwidth:g} Hz, integrator "
            f"first, computation delay {delay:g} period(s) + ½ (PWM average), no decoupling",
            "period-average voltages on the exact R-L plant in the rotor frame; switching "
            "pattern, dead time and ADC neglected; non-salient motor (torque ∝ i_q)",
            f"transducer: first-order low-pass {f_t:g} Hz",
            f"statistic of hil.analysis.nonsync over {revolutions} revolution(s), synchronous "
            f"orders 0..{max_order} removed",
            f"range [{low:g}× the smallest, {high:g}× the largest] of the trials' values (a "
            "drive is one of them: where its references sit within a count is not known), the "
            "factors from the simulated drive against it; the bench's own floor is removed from "
            "the measurement (reference point)"))
