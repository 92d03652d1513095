"""Finite PWM pulse-width resolution (paper section III-D, eqs 27-28).

Steady state in RMS phasors (EMF E = Ke·ω_m real, reactance X_s = ω_e·L_s): the current is
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
"""

from __future__ import annotations

import cmath
import math

from hil.errors import InputError
from hil.model.core import MEAN_TORQUE_BASE, OperatingPoint, Prediction, check_range

PWM_COUNTS_RANGE = (8, 65535)
PWM_BITS_RANGE = (4, 17)
BASES = ("paper", "dc_bus")


def voltage_phasor(op: OperatingPoint) -> complex:
    """RMS phase-voltage phasor V∠δ (δ from the EMF) that drives I∠−φ at the operating point."""
    motor = op.motor
    emf = motor.ke_v_s_per_rad * abs(op.mech_speed_rad_s)
    reactance = abs(op.elec_speed_rad_s) * motor.phase_inductance_h
    current = op.current_a / math.sqrt(2.0) * cmath.exp(-1j * op.current_angle_rad)
    return emf + complex(motor.phase_resistance_ohm, reactance) * current


def eq27_torque_nm(op: OperatingPoint, voltage_rms_v: float, delta_rad: float) -> float:
    """Eq 27: steady-state torque for RMS phase voltage V at angle δ ahead of the EMF."""
    motor = op.motor
    r, ke = motor.phase_resistance_ohm, motor.ke_v_s_per_rad
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
    emf = motor.ke_v_s_per_rad * abs(op.mech_speed_rad_s)
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


def predict_pwm_resolution(op: OperatingPoint, *, pwm_bits: int | None = None,
                           pwm_period_counts: int | None = None,
                           voltage_step_basis: str | None = None, model: str = "paper",
                           current_loop_bandwidth_hz: float | None = None) -> Prediction:
    """Torque step of one voltage-resolution step (eq 28), per unit of the operating torque;
    or, with ``model="closed_loop"``, the bound under the PI current loop."""
    step, basis = voltage_step_rel(op, pwm_bits=pwm_bits, pwm_period_counts=pwm_period_counts,
                                   voltage_step_basis=voltage_step_basis)
    phasor = voltage_phasor(op)
    gain = sensitivity(op)
    if model not in ("paper", "closed_loop"):
        raise InputError(f"model={model!r} is not one of paper, closed_loop")
    if model == "closed_loop":
        if current_loop_bandwidth_hz is None:
            raise InputError("model=closed_loop needs current_loop_bandwidth_hz "
                             "(allowed 10..25000 Hz)")
        bandwidth = check_range("current_loop_bandwidth_hz", current_loop_bandwidth_hz, 10.0,
                                25000.0, unit=" Hz")
        counts = pwm_period_counts if pwm_period_counts is not None else 2.0 ** (pwm_bits - 1)
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
