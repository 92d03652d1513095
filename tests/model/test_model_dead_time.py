"""Dead time: the paper's eq 38 figure and the average-voltage model against a time-domain run."""

import math
from collections import deque

import numpy as np
import pytest

from hil.model import OperatingPoint, predict
from hil.model.dead_time import PAPER_NOMINAL_CURRENT_A
from model_torque_sum import OFFSETS, balanced, torque_nm


def test_paper_two_microseconds_give_two_percent_at_the_found_nominal_current():
    assert PAPER_NOMINAL_CURRENT_A == pytest.approx(20.78, abs=0.01)
    op = OperatingPoint(speed_rpm=500, current_a=10.0)
    pred = predict("dead_time", op, dead_time_s=2e-6, nominal_current_a=PAPER_NOMINAL_CURRENT_A)
    assert round(100 * pred.pk_pk_pu, 1) == 2.0
    assert pred.order == 6.0
    at_op = predict("dead_time", OperatingPoint(speed_rpm=500, current_a=PAPER_NOMINAL_CURRENT_A),
                    dead_time_s=2e-6)
    assert at_op.pk_pk_pu == pytest.approx(pred.pk_pk_pu)


def test_eq38_current_step_in_the_torque_sum():
    """A phase-a-axis current step Δi_q moves the torque by Δi_q/I per unit only where the EMF
    vector lies on that axis; at the phase-a current zero crossing (φ = 0) it is orthogonal."""
    op = OperatingPoint(speed_rpm=500, current_a=PAPER_NOMINAL_CURRENT_A)
    pred = predict("dead_time", op, dead_time_s=2e-6)
    step = pred.extras["current_step_a"]
    axis_step = step * np.array([1.0, -0.5, -0.5])[:, None]
    theta = np.array([math.pi / 2, 0.0])  # e_a at its peak; i_a crossing zero
    ideal = balanced(theta, op.current_a)
    change = (torque_nm(theta, ideal + axis_step) - torque_nm(theta, ideal)) / op.mean_torque_nm
    assert change[0] == pytest.approx(pred.pk_pk_pu, rel=1e-9)
    assert abs(change[1]) < 1e-12


def run_drive(op, dead_time_s, f_sw, bandwidth_hz, *, sign_from_actual=True, periods=3,
              steps_per_period=6000, delay_s=0.0):
    """Forward-Euler run of the motor (abc, isolated neutral) with the average dead-time error and
    a PI current loop on both axes of the rotating current frame (Kp = ω_c·L, Ki = ω_c·R) whose
    stationary-frame output voltages are applied ``delay_s`` after they are computed."""
    motor = op.motor
    r, l = motor.phase_resistance_ohm, motor.phase_inductance_h
    w_e = op.elec_speed_rad_s
    eps = dead_time_s * f_sw * op.dc_bus_v
    wc = 2 * math.pi * bandwidth_hz if bandwidth_hz else 0.0
    kp, ki = wc * l, wc * r
    dt = 2 * math.pi / w_e / steps_per_period
    phi, amp, emf = op.current_angle_rad, op.current_a, op.emf_peak_v
    currents = [amp * math.sin(-phi - o) for o in OFFSETS]
    z1 = z2 = 0.0
    delay_steps = round(delay_s / dt)
    pending = deque([[0.0, 0.0, 0.0]] * delay_steps)
    thetas, record = [], []
    for k in range(periods * steps_per_period):
        theta = w_e * k * dt
        psi = theta - phi
        s = [math.sin(psi - o) for o in OFFSETS]
        c = [math.cos(psi - o) for o in OFFSETS]
        err1 = amp - 2 / 3 * sum(i * x for i, x in zip(currents, s))
        err2 = -2 / 3 * sum(i * x for i, x in zip(currents, c))
        z1 += ki * err1 * dt
        z2 += ki * err2 * dt
        u1, u2 = kp * err1 + z1, kp * err2 + z2
        signs = [math.copysign(1.0, i if sign_from_actual else amp * x)
                 for i, x in zip(currents, s)]
        legs = [-eps * sg for sg in signs]
        common = sum(legs) / 3
        pending.append([u1 * s[x] + u2 * c[x] for x in range(3)])
        control = pending.popleft()
        for x in range(3):
            feedforward = r * amp * s[x] + l * amp * w_e * c[x] + emf * math.sin(theta - OFFSETS[x])
            v = feedforward + control[x] + legs[x] - common
            currents[x] += dt * (v - r * currents[x] - emf * math.sin(theta - OFFSETS[x])) / l
        if k >= (periods - 1) * steps_per_period:
            thetas.append(theta)
            record.append(list(currents))
    theta = np.array(thetas)
    return theta, torque_nm(theta, np.array(record).T)


@pytest.mark.parametrize("speed_rpm,current_a,bandwidth_hz", [(1000, 20.0, 1000.0),
                                                               (500, 40.0, 500.0)])
def test_average_voltage_model_with_current_loop_matches_time_domain(speed_rpm, current_a,
                                                                     bandwidth_hz):
    op = OperatingPoint(speed_rpm=speed_rpm, current_a=current_a)
    pred = predict("dead_time", op, dead_time_s=2e-6, model="average_voltage",
                   current_loop_bandwidth_hz=bandwidth_hz)
    _, torque = run_drive(op, 2e-6, 20000, bandwidth_hz)
    measured = np.ptp(torque) / np.mean(torque)
    assert pred.pk_pk_pu == pytest.approx(measured, rel=0.10)
    assert pred.base_nm == pytest.approx(np.mean(torque), rel=0.01)


def test_average_voltage_model_with_a_delayed_loop_matches_time_domain():
    """The simulated drive's loop: bandwidth 0.08·f_pwm, 1.5 PWM periods of delay."""
    op = OperatingPoint(speed_rpm=1000, current_a=20.0)
    delay = 1.5 / 20000
    pred = predict("dead_time", op, dead_time_s=2e-6, model="average_voltage",
                   current_loop_bandwidth_hz=1600.0, current_loop_delay_s=delay)
    _, torque = run_drive(op, 2e-6, 20000, 1600.0, delay_s=delay)
    measured = np.ptp(torque) / np.mean(torque)
    assert pred.pk_pk_pu == pytest.approx(measured, rel=0.10)


def test_average_voltage_model_open_loop_harmonic_series():
    """Voltage-fed (no loop), current direction from the ideal currents as the model assumes."""
    op = OperatingPoint(speed_rpm=1000, current_a=20.0, current_angle_rad=0.3)
    pred = predict("dead_time", op, dead_time_s=1e-6, model="average_voltage")
    _, torque = run_drive(op, 1e-6, 20000, None, sign_from_actual=False, periods=4)
    assert pred.pk_pk_pu == pytest.approx(np.ptp(torque) / np.mean(torque), rel=0.02)
    assert pred.base_nm == pytest.approx(np.mean(torque), rel=0.01)
