"""PWM resolution (eqs 27-28) and PWM switching ripple (eqs 29-31) against numerical evaluation."""

import cmath
import math

import numpy as np
import pytest

from hil.model import OperatingPoint, predict
from hil.model.pwm_resolution import eq27_torque_nm, voltage_phasor
from model_torque_sum import OFFSETS, balanced, torque_nm


def steady_state_torque_nm(op, voltage_rms_v, delta_rad):
    """Torque sum of the steady-state currents a voltage V∠δ drives (phasor circuit, time domain)."""
    motor = op.motor
    emf_rms = motor.emf_rms_v_s_per_rad * abs(op.mech_speed_rad_s)
    impedance = complex(motor.phase_resistance_ohm,
                        abs(op.elec_speed_rad_s) * motor.phase_inductance_h)
    current = (cmath.rect(voltage_rms_v, delta_rad) - emf_rms) / impedance
    theta = np.linspace(0, 2 * math.pi, 3600, endpoint=False)
    currents = balanced(theta, math.sqrt(2) * abs(current), -cmath.phase(current))
    return float(np.mean(torque_nm(theta, currents)))


@pytest.mark.parametrize("speed_rpm,current_a,phi_deg", [
    (0, 20.0, 0.0), (1000, 20.0, 0.0), (1200, 40.0, 20.0), (1500, 10.0, -30.0), (500, 80.0, 45.0)])
@pytest.mark.parametrize("kwargs", [dict(pwm_bits=10), dict(pwm_period_counts=2000),
                                    dict(pwm_period_counts=500, voltage_step_basis="paper")])
def test_pwm_resolution_matches_torque_sum(speed_rpm, current_a, phi_deg, kwargs):
    op = OperatingPoint(speed_rpm=speed_rpm, current_a=current_a,
                        current_angle_rad=math.radians(phi_deg))
    pred = predict("pwm_resolution", op, **kwargs)
    phasor = voltage_phasor(op)
    v, delta = abs(phasor), cmath.phase(phasor)
    nominal = steady_state_torque_nm(op, v, delta)
    assert nominal == pytest.approx(op.mean_torque_nm, rel=1e-9)
    assert eq27_torque_nm(op, v, delta) == pytest.approx(nominal, rel=1e-9)
    stepped = steady_state_torque_nm(op, v * (1 + pred.inputs["voltage_step_rel"]), delta)
    assert pred.pk_pk_pu == pytest.approx(abs(stepped - nominal) / nominal, rel=1e-6)


def test_pwm_counts_and_bits_relation():
    op = OperatingPoint(speed_rpm=1000, current_a=20.0)
    by_bits = predict("pwm_resolution", op, pwm_bits=12)
    by_counts = predict("pwm_resolution", op, pwm_period_counts=2048, voltage_step_basis="paper")
    assert by_bits.pk_pk_pu == pytest.approx(by_counts.pk_pk_pu)
    dc_bus = predict("pwm_resolution", op, pwm_period_counts=2048)
    v_rms = abs(voltage_phasor(op))
    assert dc_bus.inputs["voltage_step_rel"] == pytest.approx(12.0 / (math.sqrt(2) * 2048 * v_rms))


def switched_period(op, theta0_rad, period_s, steps=20000, modulation="sine"):
    """Phase currents over one centre-aligned PWM period starting at angle θ0 (ideal switches)."""
    motor = op.motor
    phasor = voltage_phasor(op)
    v_peak, delta = math.sqrt(2) * abs(phasor), cmath.phase(phasor)
    reference = v_peak * np.sin(theta0_rad + delta - OFFSETS)
    if modulation == "svpwm":
        reference = reference - 0.5 * (reference.max() + reference.min())
    duties = 0.5 + reference / op.dc_bus_v
    dt = period_s / steps
    t = (np.arange(steps) + 0.5) * dt
    carrier = 1 - np.abs(2 * t / period_s - 1)  # 1 → 0 → 1: legs high while duty > carrier
    states = (duties[:, None] > carrier[None, :]).astype(float)
    phase_v = op.dc_bus_v * (states - states.mean(axis=0))
    theta = theta0_rad + op.elec_speed_rad_s * t
    emf = op.emf_peak_v * np.sin(theta[None, :] - OFFSETS[:, None])
    start = balanced(np.array([theta0_rad]), op.current_a, op.current_angle_rad)
    trace = np.repeat(start, steps, axis=1)
    for _ in range(3):  # forward Euler, the R·i drop iterated to convergence (Picard)
        slope = (phase_v - motor.phase_resistance_ohm * trace - emf) / motor.phase_inductance_h
        trace = start + np.cumsum(slope * dt, axis=1)
    return theta, trace


def detrended_ptp(signal):
    line = np.linspace(signal[0], signal[-1], signal.size)
    return float(np.ptp(signal - line))


@pytest.mark.parametrize("speed_rpm,current_a,f_sw", [(1000, 20.0, 20000), (300, 10.0, 10000),
                                                      (1200, 30.0, 40000)])
def test_pwm_switching_current_ripple_at_voltage_zero_crossing(speed_rpm, current_a, f_sw):
    op = OperatingPoint(speed_rpm=speed_rpm, current_a=current_a)
    pred = predict("pwm_switching", op, pwm_frequency_hz=f_sw)
    delta = cmath.phase(voltage_phasor(op))
    theta0 = 2 * math.pi / 3 - delta  # phase-b voltage reference crosses zero
    _, currents = switched_period(op, theta0, 1 / f_sw)
    assert detrended_ptp(currents[1]) == pytest.approx(pred.extras["current_ripple_pk_pk_a"],
                                                       rel=0.02)
    assert pred.pk_pk_pu == pytest.approx(pred.extras["current_ripple_pk_pk_a"] / current_a)
    assert pred.order == 6.0
    assert np.max(pred.waveform_pu) == pytest.approx(pred.pk_pk_pu, rel=1e-2)


def test_pwm_switching_torque_versus_the_papers_current_equivalence():
    """The paper equates the per-unit torque ripple with the per-unit phase-current ripple."""
    op = OperatingPoint(speed_rpm=1000, current_a=20.0)
    pred = predict("pwm_switching", op, pwm_frequency_hz=20000)
    delta = cmath.phase(voltage_phasor(op))
    ratios = []
    for theta0 in 2 * math.pi / 3 - delta + np.radians([0.0, 10.0, 20.0, 30.0]):
        theta, currents = switched_period(op, theta0, 1 / 20000)
        torque = torque_nm(theta, currents)
        ratios.append(detrended_ptp(torque) / op.mean_torque_nm / pred.pk_pk_pu)
    print("torque-sum pk-pk / paper's prediction at 0, 10, 20, 30 deg:", np.round(ratios, 3))
    assert 0.5 < ratios[0] < 2.0  # same magnitude at the zero crossing, as the paper claims


@pytest.mark.parametrize("modulation", ["svpwm", "sine"])
@pytest.mark.parametrize("speed_rpm,current_a,f_sw", [(1000, 20.0, 20000), (300, 10.0, 10000),
                                                      (1200, 30.0, 40000)])
def test_switched_torque_form_matches_torque_sum(speed_rpm, current_a, f_sw, modulation):
    op = OperatingPoint(speed_rpm=speed_rpm, current_a=current_a)
    pred = predict("pwm_switching", op, pwm_frequency_hz=f_sw, model="switched_torque",
                   modulation=modulation)
    for index in range(0, 1200, 97):  # a third of a revolution, every 9.7°
        theta0 = pred.angle_rad[index]
        theta, currents = switched_period(op, theta0, 1 / f_sw, steps=8000, modulation=modulation)
        measured = detrended_ptp(torque_nm(theta, currents)) / op.mean_torque_nm
        assert pred.waveform_pu[index] == pytest.approx(measured, rel=0.03)
    assert pred.pk_pk_pu == pytest.approx(np.max(pred.waveform_pu))


def run_quantized_drive(op, counts, bandwidth_hz, f_sw=20000.0, periods=2, substeps=4):
    """Per-PWM-period average model: PI loop (Kp = ω_c·L, Ki = ω_c·R) in the current frame,
    SVPWM leg references with the duty truncated to 1/C, plant integrated within each period."""
    motor = op.motor
    r, l = motor.phase_resistance_ohm, motor.phase_inductance_h
    w_e, amp, emf = op.elec_speed_rad_s, op.current_a, op.emf_peak_v
    wc = 2 * math.pi * bandwidth_hz
    kp, ki = wc * l, wc * r
    t_s = 1 / f_sw
    n_periods = int(periods * 2 * math.pi / w_e / t_s)
    currents = amp * np.sin(-OFFSETS)
    z = np.zeros(2)
    thetas, torques = [], []
    for k in range(n_periods):
        theta = w_e * k * t_s
        s, c = np.sin(theta - OFFSETS), np.cos(theta - OFFSETS)
        err = np.array([amp - 2 / 3 * currents @ s, -2 / 3 * currents @ c])
        z += ki * err * t_s
        u = kp * err + z
        feedforward = r * amp * s + l * amp * w_e * c + emf * s
        phase_ref = feedforward + u[0] * s + u[1] * c
        legs = phase_ref - 0.5 * (phase_ref.max() + phase_ref.min())
        duties = np.floor((0.5 + legs / op.dc_bus_v) * counts) / counts
        applied = op.dc_bus_v * (duties - duties.mean())
        for j in range(substeps):
            angle = theta + w_e * (j + 0.5) * t_s / substeps
            back_emf = emf * np.sin(angle - OFFSETS)
            currents = currents + t_s / substeps * (applied - r * currents - back_emf) / l
            if k > n_periods // 4:
                thetas.append(angle)
                torques.append(torque_nm(np.array([angle]), currents[:, None])[0])
    return np.array(thetas), np.array(torques)


@pytest.mark.parametrize("counts", [32, 128])
def test_pwm_resolution_closed_loop_bound_holds_in_a_quantized_loop(counts):
    op = OperatingPoint(speed_rpm=1000, current_a=20.0)
    pred = predict("pwm_resolution", op, pwm_period_counts=counts, model="closed_loop",
                   current_loop_bandwidth_hz=1600.0)
    _, torque = run_quantized_drive(op, counts, 1600.0)
    measured = np.ptp(torque) / np.mean(torque)
    print(f"C={counts}: quantized loop {measured:.4f}, closed-loop bound {pred.pk_pk_pu:.4f}, "
          f"open-loop eq 28 {pred.extras['paper_pk_pk_pu']:.4f}")
    assert measured <= pred.pk_pk_pu < pred.extras["paper_pk_pk_pu"]
