"""Finite PWM pulse-width resolution (paper section III-D, eqs 27-28).

Steady state in RMS phasors (EMF E = Ke·ω_m real, Ke the RMS phase EMF constant
``emf_rms_v_s_per_rad`` whatever the nameplate's definition; reactance X_s = ω_e·L_s): the current is
(V∠δ − E)/(R + jX_s) and the torque 3·E·Re(I)/ω_m is eq 27,
T = 3·Ke·[(V·cos δ − Ke·ω_m)·R + X_s·V·sin δ]/(R² + X_s²). A voltage step ΔV (the "hysteresis
band" of the duty register) at fixed δ moves the torque by ∂T/∂V·ΔV, so (eq 28)

    ΔT/T = (ΔV/V)·(R·cos δ + X_s·sin δ)/((cos δ − E/V)·R + X_s·sin δ).

V and δ follow from the operating point (I, φ, speed) through the same phasor circuit.
Voltage step: the paper's n-bit register gives ΔV/V = 1/2^(n−1) (``pwm_bits``), relative to the
operating voltage. A centre-aligned counter of C counts per half period (``pwm_period_counts``)
has duty steps of 1/C, i.e. a leg-voltage step of V_dc/C and a peak phase-voltage step of at most
V_dc/C: ΔV/V = V_dc/(√2·C·V) ("dc_bus" basis, the default for counts). The "paper" basis with
counts reads C as 2^(n−1): ΔV/V = 1/C, which equals the dc-bus basis only at V = V_dc/√2.

Eq 28 is open loop: a current loop integrates a steady voltage error away. With the PI loop
(``current_loop_bandwidth_hz`` given; Kp = ω_c·L_s, Ki = ω_c·R) the truncated duties act as a
voltage disturbance whose space vector is at most (2/3)·V_dc/C (each leg low by less than one
count). Its current response h(t) = L⁻¹{s/((R + L_s·s)(s + ω_c))} has the L1 norm
2·(e^(−a·t0) − e^(−ω_c·t0))/(L_s·(ω_c − a)), a = R/L_s, t0 = ln(ω_c/a)/(ω_c − a), so the q current
stays within ±(2/3)·(V_dc/C)·‖h‖₁ and the pk-pk torque per unit of the mean torque is at most
2·(2/3)·(V_dc/C)·‖h‖₁/(I·cos φ) (``model="closed_loop"``, a bound not in the paper; the loop's
delay and cross-coupling are neglected).

A bound cannot fail for a drive that ignores the injection. ``model="derived"`` (not in the paper)
gives a value: the duty quantisation as an additive disturbance. Each PWM period k the firmware's
compare value is floor((½ + v_x/V_dc)·C), so leg x gets the voltage error
e_x[k] = (floor((½ + v_x/V_dc)·C)/C − ½ − v_x/V_dc)·V_dc, computed here from the steady-state leg
references (the phasor V∠δ of eq 27's circuit, SVPWM or sine) sampled at the PWM rate over whole
electrical revolutions. Its common mode does not reach an isolated-neutral motor; its space
vector u[k] = (2/3)·Σ_x e_x[k]·e^(j·o_x) drives the current through the loop's disturbance
response (``dead_time.loop_rejection``: plant 1/(R + L·(s + jω_e)) in the rotor frame, PI
Kp = ω_c·L, Ki = ω_c·R, delay τ), evaluated per frequency of u. The torque ripple is
Re(ê·conj(Δi))/(I·cos φ) (ê the unit EMF vector), low-passed to ``max_order`` and taken over one
revolution (synchronous), pk-pk. Where the references fall on the count grid decides which steps
occur, and a real loop moves them by a fraction of a count (its own reaction, ADC noise): the
single-revolution value is the mean over ``OFFSET_TRIALS`` leg offsets spread evenly over one
count (their min and max are in ``extras``). That movement also changes the pattern from one
revolution to the next, so the synchronous average of R revolutions (``revolutions_averaged``,
the capture's whole revolutions) keeps about 1/√R of it: the value is the single-revolution
figure over √R. (The twin bears this out: at 500 rpm, 20 A, C = 32 its synchronously averaged
air-gap ripple falls from 3.5 % over 2 revolutions to 1.5 % over 8 and 1.3 % over 32.)
Against the simulated drive (air-gap torque through ``hil.analysis``, 250–1500 rpm, 20–40 A,
C = 32 and 128, R = 2, 8, 32, within the voltage limit: 42 points) the twin lay between 0.40 and
2.53 times this value — high ratios at R = 32, where the twin's own floor and its synchronous
part remain — so the expected range is [value/3, 3·value] (``DERIVED_RANGE_FACTORS``). Beyond
the linear modulation range the loop saturates (the twin was 2–4 times higher there): such
points are refused.
"""

from __future__ import annotations

import cmath
import dataclasses
import math

import numpy as np

from hil.current_loop import PI_DESIGNS
from hil.errors import InputError
from hil.model.core import (MEAN_TORQUE_BASE, PHASE_OFFSETS_RAD, OperatingPoint, Prediction,
                            check_range)
from hil.model.dead_time import loop_rejection

PWM_COUNTS_RANGE = (8, 65535)
PWM_BITS_RANGE = (4, 17)
BASES = ("paper", "dc_bus")
MODELS = ("paper", "closed_loop", "derived")
MODULATIONS = ("svpwm", "sine")
#: The stated loop designs this model represents: a PI (the discrete one by its equivalent
#: bandwidth, ``hil.current_loop``); ``hil.validity`` refuses a point on another.
REPRESENTED_LOOP_DESIGNS = PI_DESIGNS
#: Expected range of the derived model, (low, high) factors of its value: the spread of the
#: simulated drive against it over the validation grid (module docstring), rounded outward.
#: Out of sample (``studies/pwm_calibration.py``, hil/model/README.md): calibration 0.37-0.93x,
#: holdout 0.31-1.46x; the point's U is of the order of its value, so this range cannot catch a
#: 2x model and the plan's noise check (``pwm_noise.NOISE_RANGE_FACTORS``) carries that verdict.
DERIVED_RANGE_FACTORS = (1.0 / 3.0, 3.0)
#: Highest electrical order the analysis keeps by default (hil.analysis DEFAULT_MAX_ORDER).
DEFAULT_MAX_ORDER = 64
MAX_REVOLUTIONS = 64
#: Leg offsets (fractions of a count) the derived form averages over (module docstring).
OFFSET_TRIALS = 16
#: Revolutions a capture's synchronous average spans unless stated: hil.measurement's default
#: capture of 8 electrical revolutions per point (as DEFAULT_MAX_ORDER mirrors the analysis).
DEFAULT_REVOLUTIONS_AVERAGED = 8


def voltage_phasor(op: OperatingPoint) -> complex:
    """RMS phase-voltage phasor V∠δ (δ from the EMF) that drives I∠−φ at the operating point."""
    return op.voltage_phasor_peak_v / math.sqrt(2.0)


def eq27_torque_nm(op: OperatingPoint, voltage_rms_v: float, delta_rad: float) -> float:
    """Eq 27: steady-state torque for RMS phase voltage V at angle δ ahead of the EMF."""
    motor = op.motor
    r, ke = motor.phase_resistance_ohm, motor.emf_rms_v_s_per_rad
    x = abs(op.elec_speed_rad_s) * motor.phase_inductance_h
    emf = ke * abs(op.mech_speed_rad_s)
    return 3.0 * ke * ((voltage_rms_v * math.cos(delta_rad) - emf) * r
                       + x * voltage_rms_v * math.sin(delta_rad)) / (r * r + x * x)


def sensitivity(op: OperatingPoint) -> float:
    """Eq 28 without the step: (ΔT/T)/(ΔV/V) at the operating point."""
    motor = op.motor
    r = motor.phase_resistance_ohm
    x = abs(op.elec_speed_rad_s) * motor.phase_inductance_h
    phasor = voltage_phasor(op)
    v, delta = abs(phasor), cmath.phase(phasor)
    emf = motor.emf_rms_v_s_per_rad * abs(op.mech_speed_rad_s)
    return (math.cos(delta) * r + x * math.sin(delta)) / (
        (math.cos(delta) - emf / v) * r + x * math.sin(delta))


def voltage_step_rel(op: OperatingPoint, *, pwm_bits: int | None = None,
                     pwm_period_counts: int | None = None,
                     voltage_step_basis: str | None = None) -> tuple[float, str]:
    """(ΔV/V, basis used) from a register width or a counter top value."""
    if (pwm_bits is None) == (pwm_period_counts is None):
        raise InputError("give exactly one of pwm_bits (allowed 4..17) or pwm_period_counts "
                         "(allowed 8..65535)")
    basis = voltage_step_basis or ("paper" if pwm_bits is not None else "dc_bus")
    if basis not in BASES:
        raise InputError(f"voltage_step_basis={basis!r} is not one of {', '.join(BASES)}")
    if pwm_bits is not None:
        bits = check_range("pwm_bits", pwm_bits, *PWM_BITS_RANGE, unit=" bits")
        counts = 2.0 ** (int(bits) - 1)
    else:
        counts = check_range("pwm_period_counts", pwm_period_counts, *PWM_COUNTS_RANGE,
                             unit=" counts")
    if basis == "paper":
        return 1.0 / counts, basis
    return op.dc_bus_v / (math.sqrt(2.0) * counts * abs(voltage_phasor(op))), basis


def loop_l1_norm_a_per_v(op: OperatingPoint, bandwidth_hz: float) -> float:
    """‖h‖₁ of the voltage-disturbance → current response of the PI loop, A per V (docstring)."""
    omega_c = 2.0 * math.pi * bandwidth_hz
    inductance = op.motor.phase_inductance_h
    a = op.motor.phase_resistance_ohm / inductance
    t0 = math.log(omega_c / a) / (omega_c - a)
    return 2.0 * (math.exp(-a * t0) - math.exp(-omega_c * t0)) / (inductance * (omega_c - a))


def closed_loop_bound_pu(op: OperatingPoint, counts: float, bandwidth_hz: float) -> float:
    """Pk-pk torque bound per unit of the mean torque for duty steps of 1/C under a PI loop."""
    disturbance_v = (2.0 / 3.0) * op.dc_bus_v / counts
    return 2.0 * disturbance_v * loop_l1_norm_a_per_v(op, bandwidth_hz) / (
        op.current_a * math.cos(op.current_angle_rad))


def forward_phasor_peak_v(op: OperatingPoint) -> complex:
    """Peak phase-voltage phasor (angle from the EMF) of the forward-rotating problem
    equivalent to ``op``. Forward: ``op.voltage_phasor_peak_v``. Reverse: the drive still
    commands I·e^(−jφ) on the forward q axis while the EMF is −E, so it brakes:
    V = −E + (R − j·|ω_e|·L)·I·e^(−jφ); swapping two phases (d kept, q reversed, −conj of every
    dq phasor) makes that the forward problem V' = E + (R + j·|ω_e|·L)·(−I·e^(+jφ)), a current
    at π − φ behind the EMF (not mirrored motoring, which would keep φ)."""
    if op.speed_rpm >= 0.0:
        return op.voltage_phasor_peak_v
    motor = op.motor
    current = -op.current_a * cmath.exp(1j * op.current_angle_rad)
    reactance = abs(op.elec_speed_rad_s) * motor.phase_inductance_h
    return op.emf_peak_v + complex(motor.phase_resistance_ohm, reactance) * current


def leg_references_pu(theta: np.ndarray, op: OperatingPoint, modulation: str) -> np.ndarray:
    """Steady-state leg voltage references, per unit of V_dc, at electrical angles θ (3 × N) of
    the forward-rotating equivalent of ``op`` (``forward_phasor_peak_v``)."""
    phasor = forward_phasor_peak_v(op)
    v_peak, delta = abs(phasor), cmath.phase(phasor)
    reference = v_peak * np.sin(theta[None, :] + delta - PHASE_OFFSETS_RAD[:, None]) / op.dc_bus_v
    if modulation == "svpwm":
        reference = reference - 0.5 * (reference.max(axis=0) + reference.min(axis=0))
    return reference


def whole_revolutions(periods_per_rev: float) -> int:
    """Fewest revolutions (≤ MAX_REVOLUTIONS) holding a whole number of PWM periods, else the
    count that comes closest."""
    mismatch = [abs(r * periods_per_rev - round(r * periods_per_rev))
                for r in range(1, MAX_REVOLUTIONS + 1)]
    whole = [r for r, miss in enumerate(mismatch, start=1) if miss <= 1e-6]
    return whole[0] if whole else 1 + int(np.argmin(mismatch))


def grid_offsets(trials: int) -> np.ndarray:
    """``trials`` × 3 leg offsets in [0, 1) counts, evenly spread (a Kronecker sequence)."""
    steps = np.array([0.7548776662466927, 0.5698402909980532, 0.4301597090019468])
    return np.mod(0.5 + np.arange(trials)[:, None] * steps[None, :], 1.0)


def derived_pk_pk_pu(op: OperatingPoint, counts: float, *, pwm_frequency_hz: float,
                     bandwidth_hz: float, delay_s: float = 0.0, modulation: str = "svpwm",
                     max_order: int = DEFAULT_MAX_ORDER,
                     trials: int = OFFSET_TRIALS) -> tuple[float, float, float]:
    """(mean, min, max over the leg offsets) of one revolution's synchronous pk-pk, per unit of
    the mean torque (module docstring)."""
    omega_e = abs(op.elec_speed_rad_s)
    periods_per_rev = 2.0 * math.pi * pwm_frequency_hz / omega_e
    span = whole_revolutions(periods_per_rev)     # revolutions holding whole PWM periods
    n = int(round(span * periods_per_rev))
    theta = omega_e * np.arange(n) / pwm_frequency_hz
    reference = leg_references_pu(theta, op, modulation)
    omega = 2.0 * math.pi * np.fft.fftfreq(n, 1.0 / pwm_frequency_hz)
    # the loop's rejection depends on |ω_e| only; the references carry the braking (above)
    forward = dataclasses.replace(op, speed_rpm=abs(op.speed_rpm))
    response = loop_rejection(omega - omega_e, forward, 2.0 * math.pi * bandwidth_hz, delay_s)
    orders = np.arange(n // 2 + 1) / span
    keep = (orders <= max_order) & (np.abs(orders - np.round(orders)) < 1e-9) & (orders > 0)
    emf_direction = np.exp(1j * (theta - math.pi / 2))
    active_a = op.current_a * math.cos(op.current_angle_rad)
    values = []
    for offset in grid_offsets(trials):
        shifted = reference + offset[:, None] / counts
        error_v = (np.floor((0.5 + shifted) * counts) / counts - 0.5 - shifted) * op.dc_bus_v
        vector = (2.0 / 3.0) * np.sum(error_v * np.exp(1j * PHASE_OFFSETS_RAD)[:, None], axis=0)
        current = np.fft.ifft(np.fft.fft(vector) * response)
        ripple = np.real(emf_direction * np.conj(current)) / active_a
        values.append(float(np.ptp(np.fft.irfft(np.where(keep, np.fft.rfft(ripple), 0.0), n))))
    return float(np.mean(values)), min(values), max(values)


def predict_pwm_resolution(op: OperatingPoint, *, pwm_bits: int | None = None,
                           pwm_period_counts: int | None = None,
                           voltage_step_basis: str | None = None, model: str = "paper",
                           current_loop_bandwidth_hz: float | None = None,
                           current_loop_delay_s: float = 0.0, pwm_frequency_hz: float = 20000.0,
                           modulation: str = "svpwm", max_order: int = DEFAULT_MAX_ORDER,
                           revolutions_averaged: int = DEFAULT_REVOLUTIONS_AVERAGED
                           ) -> Prediction:
    """Torque step of one voltage-resolution step (eq 28), per unit of the operating torque;
    with ``model="closed_loop"`` the bound under the PI current loop; with ``model="derived"``
    the duty-quantisation ripple through the loop (module docstring)."""
    step, basis = voltage_step_rel(op, pwm_bits=pwm_bits, pwm_period_counts=pwm_period_counts,
                                   voltage_step_basis=voltage_step_basis)
    phasor = voltage_phasor(op)
    gain = sensitivity(op)
    if model not in MODELS:
        raise InputError(f"model={model!r} is not one of {', '.join(MODELS)}")
    if model in ("closed_loop", "derived"):
        if current_loop_bandwidth_hz is None:
            raise InputError(f"model={model} needs current_loop_bandwidth_hz "
                             "(allowed 10..25000 Hz)")
        bandwidth = check_range("current_loop_bandwidth_hz", current_loop_bandwidth_hz, 10.0,
                                25000.0, unit=" Hz")
        counts = pwm_period_counts if pwm_period_counts is not None else 2.0 ** (pwm_bits - 1)
    if model == "derived":
        return _derived_prediction(op, counts, bandwidth, current_loop_delay_s, pwm_frequency_hz,
                                   modulation, max_order, revolutions_averaged,
                                   abs(step * gain), closed_loop_bound_pu(op, counts, bandwidth))
    if model == "closed_loop":
        return Prediction(
            source="pwm_resolution", pk_pk_pu=closed_loop_bound_pu(op, counts, bandwidth),
            base=MEAN_TORQUE_BASE, base_nm=op.mean_torque_nm, order=None,
            inputs={"pwm_bits": pwm_bits, "pwm_period_counts": pwm_period_counts,
                    "model": model, "current_loop_bandwidth_hz": bandwidth, **op.to_dict()},
            equations="closed-loop bound (not in the paper; eqs 27-28 for the open-loop form)",
            assumptions=[
                "duties truncated to 1/C: voltage disturbance vector at most (2/3)·V_dc/C",
                "PI loop Kp = ω_c·L_s, Ki = ω_c·R; delay and cross-coupling neglected",
                "worst-case bound (an adversarial disturbance); typical ripple is smaller"],
            extras={"paper_pk_pk_pu": abs(step * gain), "voltage_step_rel": step})
    return Prediction(
        source="pwm_resolution", pk_pk_pu=abs(step * gain), base=MEAN_TORQUE_BASE,
        base_nm=op.mean_torque_nm, order=None,
        inputs={"pwm_bits": pwm_bits, "pwm_period_counts": pwm_period_counts,
                "voltage_step_basis": basis, "voltage_step_rel": step, "model": model,
                **op.to_dict()},
        equations="eqs 27-28", assumptions=[
            "steady-state phasor circuit, sinusoidal EMF, voltage command in open loop",
            "the duty register toggles by one step (a band ΔV) at fixed voltage angle δ",
            "pk-pk torque = one voltage step's torque change (first order)"],
        extras={"voltage_rms_v": abs(phasor), "delta_rad": cmath.phase(phasor),
                "sensitivity": gain})


def _derived_prediction(op: OperatingPoint, counts: float, bandwidth_hz: float, delay_s: float,
                        pwm_frequency_hz: float, modulation: str, max_order: int,
                        revolutions_averaged: int, paper_pu: float,
                        bound_pu: float) -> Prediction:
    if op.speed_rpm == 0.0:
        raise InputError("speed_rpm=0: the derived form averages whole electrical revolutions "
                         "(allowed: speed_rpm != 0 with model=derived)")
    f_sw = check_range("pwm_frequency_hz", pwm_frequency_hz, 2000.0, 50000.0, unit=" Hz")
    delay = check_range("current_loop_delay_s", delay_s, 0.0, 1e-3, unit=" s")
    if modulation not in MODULATIONS:
        raise InputError(f"modulation={modulation!r} is not one of {', '.join(MODULATIONS)}")
    orders = check_range("max_order", max_order, 1, 10000)
    v_peak = abs(forward_phasor_peak_v(op))
    linear_limit = op.dc_bus_v / (math.sqrt(3.0) if modulation == "svpwm" else 2.0)
    if v_peak > linear_limit:
        raise InputError(f"the operating point needs a {v_peak:.3g} V peak phase voltage, beyond "
                         f"the {modulation} linear range {linear_limit:.3g} V of the "
                         f"{op.dc_bus_v:g} V bus (allowed: lower speed or current)")
    revolutions = check_range("revolutions_averaged", revolutions_averaged, 1, 1000)
    if revolutions != int(revolutions):
        raise InputError(f"revolutions_averaged={revolutions_averaged!r} is not an integer "
                         "(allowed 1..1000)")
    revolutions = int(revolutions)
    single, lowest, highest = derived_pk_pk_pu(
        op, counts, pwm_frequency_hz=f_sw, bandwidth_hz=bandwidth_hz, delay_s=delay,
        modulation=modulation, max_order=int(orders))
    value = single / math.sqrt(revolutions)  # the pattern changes from revolution to revolution
    low, high = DERIVED_RANGE_FACTORS
    return Prediction(
        source="pwm_resolution", pk_pk_pu=value, base=MEAN_TORQUE_BASE,
        base_nm=op.mean_torque_nm, order=None,
        inputs={"pwm_period_counts": counts, "model": "derived",
                "current_loop_bandwidth_hz": bandwidth_hz, "current_loop_delay_s": delay,
                "pwm_frequency_hz": f_sw, "modulation": modulation, "max_order": int(orders),
                "revolutions_averaged": revolutions, **op.to_dict()},
        equations="duty quantisation through the current loop (not in the paper; eqs 27-28 for "
                  "the open-loop form)",
        assumptions=[
            "compare values truncated to whole counts of the steady-state leg references",
            "additive disturbance: the loop's reaction does not move the quantisation steps",
            f"PI loop Kp = ω_c·L_s, Ki = ω_c·R, delay {delay:.3g} s (continuous-time)",
            f"one revolution's synchronous pattern, mean over {OFFSET_TRIALS} leg offsets within "
            f"a count (the loop moves the steps), orders 1..{int(orders)}, divided by √R for the "
            f"synchronous average of R = {revolutions} revolution(s)",
            "air-gap torque (a transducer's bandwidth below the ripple lowers the reading)",
            "range [value/3, 3·value] from the spread against the simulated drive; the "
            "drive's own ripple floor (baseline) is not included"],
        expected_range_pu=(low * value, high * value),
        extras={"paper_pk_pk_pu": paper_pu, "closed_loop_bound_pu": bound_pu,
                "single_revolution_pk_pk_pu": single, "offset_trials_min_pu": lowest,
                "offset_trials_max_pu": highest})
