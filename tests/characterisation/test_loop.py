"""``hil.characterisation.loop``: the loop model against the simulated firmware it describes, and
the drive's frame found from where the drive holds its current (issue 29, coverage of the loop
gain: studies/results/characterisation_coverage.md)."""

import math
from dataclasses import replace

import numpy as np
import pytest

from hil.capture import Capture
from hil.characterisation.identify import phasors_per_revolution
from hil.characterisation.loop import (LoopSetup, angle_quantisation, drive_frame_rad,
                                       dq_current, model_response, phase_voltage_peak_v,
                                       pi_controller, pulse_hold, response, svpwm_duties)
from hil.motor import MotorParameters
from hil.sim import DriveTwin
from hil.sim.config import DriveConfig, FirmwareModel, MotorModel, SensorModel
from hil.sim.firmware import _pi_axis

PWM_HZ = 20_000.0
POLE_PAIRS = 2


def test_the_model_pi_is_the_firmwares():
    """The firmware's PI step adds the present error to the integrator before its output: its
    impulse response is Kp + Ki·Ts, then Ki·Ts — whose z-transform is the model's
    C(z) = Kp + Ki·Ts·z/(z − 1), not the forward-Euler Kp + Ki·Ts/(z − 1) the model first had
    (Ki·Ts/Kp = R·Ts/L: 7 % more proportional gain at Table I)."""
    kp, ki_ts = 0.4, 0.03
    integrator, impulse = 0.0, []
    for error in [1.0] + [0.0] * 199:
        output, integrator = _pi_axis(error, 0.0, integrator, kp, ki_ts, 10.0, (0.0, 0.0), 0.0)
        impulse.append(output)
    assert impulse[:3] == pytest.approx([kp + ki_ts, ki_ts, ki_ts], rel=1e-12)
    z = 1.5                                  # inside the region of convergence, |z| > 1
    transform = sum(h * z ** -n for n, h in enumerate(impulse))
    assert pi_controller(z, kp, ki_ts) == pytest.approx(transform, rel=1e-12)


def test_pulse_hold_tends_to_the_held_mean_and_depends_on_the_duty():
    """Centred pulses: e^{−jΩTs/2}·cos(Ω·d·Ts/2); at d = ½ (ΩTs)²/96 above the held mean's
    sinc(ΩTs/2), and both → 1 as ΩTs → 0."""
    period = 1.0 / PWM_HZ
    stator = 2 * math.pi * 1600.0
    half = pulse_hold(stator, period, (0.5,))
    held = np.sinc(stator * period / (2 * math.pi))
    x = stator * period
    assert abs(half) / held - 1.0 == pytest.approx(x ** 2 / 96, rel=0.05)
    assert np.angle(half) == pytest.approx(-x / 2)
    assert abs(pulse_hold(1e-3, period, (0.1, 0.9))) == pytest.approx(1.0, abs=1e-9)


def test_angle_quantisation_spans_a_fixed_and_a_uniform_truncation():
    """The factor lies between sinc² (uniform truncation, both sides) and sinc (the drive's fixed),
    its rectangular u reaching both."""
    count = 2 * math.pi * POLE_PAIRS / 7200
    factor, u = angle_quantisation([24, 96, 155], count)
    s = np.sinc(np.array([24, 96, 155]) * count / (2 * math.pi))
    assert np.all(factor * (1 - math.sqrt(3) * u) == pytest.approx(s ** 2))
    assert np.all(factor * (1 + math.sqrt(3) * u) == pytest.approx(s))


def _synthetic(frame_rad, current_angle_rad, order, response_h, amplitude=2.0, current=20.0):
    """Phase currents of a drive whose frame is the angle channel's + ``frame_rad``, holding
    i_q* = I·cos φ, i_d* = −I·sin φ and answering its test signal A·sin(k·θ_drive) on q with
    ``response_h``."""
    rate, speed = 47_317.0, 500.0
    omega_e = POLE_PAIRS * speed / 60 * 2 * math.pi
    t = np.arange(int(8.25 * 2 * math.pi / omega_e * rate)) / rate
    theta = 0.2 + omega_e * t
    drive = theta + frame_rad
    i_q = current * math.cos(current_angle_rad) + amplitude * abs(response_h) * np.sin(
        order * drive + np.angle(response_h))
    i_d = -current * math.sin(current_angle_rad) + 0.0 * t
    phases = [i_q * np.sin(drive - x * 2 * math.pi / 3) + i_d * np.cos(drive - x * 2 * math.pi / 3)
              for x in range(3)]
    return Capture({"time_s": t, "rotor_angle_mech_rad": theta / POLE_PAIRS,
                    "ia_a": phases[0], "ib_a": phases[1]}), theta


@pytest.mark.parametrize("frame_rad, current_angle_rad", [(0.0, 0.0), (0.52, 0.0), (-0.003, 0.4)])
def test_the_response_is_read_in_the_drives_own_frame(frame_rad, current_angle_rad):
    """A DAQ angle channel 30° (0.52 rad) or a fraction of a count off the drive's frame: the
    frame is found from where the drive holds its current, and H_k comes out as the drive
    answered, not turned by k times the offset."""
    h = 1.05 * np.exp(-0.4j)
    capture, theta = _synthetic(frame_rad, current_angle_rad, 48, h)
    frame, u_frame = drive_frame_rad(capture, theta, current_angle_rad, 48)
    assert frame == pytest.approx(frame_rad, abs=1e-9) and u_frame < 1e-9
    measured, u = response(capture, POLE_PAIRS, 48, 2.0, current_angle_rad)
    assert measured == pytest.approx(h, abs=1e-9)
    assert u < 1e-9


def _twin_response(gain, order, speed_rpm=600.0, current_a=15.0):
    """H_k of the simulated drive (Table I nameplate, the plant's L 20 % below it, a loop at
    ``gain`` × 1600 Hz), from its exact currents and a fine encoder (no angle quantisation)."""
    stated = MotorParameters()
    plant = replace(stated, phase_inductance_h=0.8 * stated.phase_inductance_h,
                    phase_resistance_ohm=1.3 * stated.phase_resistance_ohm)
    config = DriveConfig(motor=MotorModel(parameters=plant),
                         firmware=FirmwareModel(bandwidth_per_pwm=0.08 * gain, tuning=stated),
                         sensors=SensorModel(encoder_counts_per_rev=1 << 20),
                         current_command_a=current_a, speed_rpm=speed_rpm)
    twin = DriveTwin(config)
    amplitude = 0.1 * current_a
    twin.set_injection(loop_test_amplitude_a=amplitude, loop_test_order=order)
    f_e = speed_rpm / 60 * POLE_PAIRS
    twin.advance(0.05, 1000.0, channels=())
    data = twin.advance(8 / f_e, 47_317.0, channels=["rotor_angle_mech_rad", "ia_a", "ib_a"])
    theta = np.unwrap(data["rotor_angle_mech_rad"]) * POLE_PAIRS
    _, i_q = dq_current(data, theta)
    measured = phasors_per_revolution(i_q, theta, order).mean() / (-1j * amplitude)
    return measured, stated, plant, config


@pytest.mark.parametrize("gain", [1.25])
def test_the_model_meets_the_simulated_firmware(gain):
    """The loop model at the simulated drive's own g, R, L and operating point's PWM duties: |H|
    within 0.1 % and its phase within 2 mrad at ¼, ½ and 1 × the documented bandwidth (the
    first model — forward-Euler PI, the current at the sampling instants — was 2.6 % and
    0.06 rad off at the top order of this loop)."""
    omega_e = 600.0 / 60 * 2 * math.pi * POLE_PAIRS
    for order in (20, 40, 80):
        measured, stated, plant, config = _twin_response(gain, order)
        motor = (plant.phase_resistance_ohm, plant.phase_inductance_h)
        voltage = phase_voltage_peak_v(15.0, 0.0, omega_e,
                                       plant.emf_peak_v_s_per_rad * omega_e / POLE_PAIRS, motor)
        setup = LoopSetup(omega_e_rad_s=omega_e, bandwidth_hz=1600.0, delay_s=75e-6,
                          tuned=(stated.phase_resistance_ohm, stated.phase_inductance_h),
                          pwm_hz=PWM_HZ, duties=svpwm_duties(voltage, stated.dc_bus_v))
        model = complex(model_response(order * omega_e, gain, motor, setup))
        assert abs(measured) / abs(model) - 1 == pytest.approx(0.0, abs=1e-3), order
        assert np.angle(measured / model) == pytest.approx(0.0, abs=2e-3), order
