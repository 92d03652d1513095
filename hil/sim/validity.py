"""Where the twin's inverter stays linear: the duty headroom of an operating point.

The firmware's modulator emits no pulse wider than N·(1 − 2·t_d/T) short of full-on (a pulse
must leave one dead time before the period ends, ``hil.sim.firmware._compare``). When the steady
voltage the loop needs puts the highest leg's duty above that, the leg clips, the loop winds up
against a limit its anti-windup does not see (that watches only |v| ≤ V_dc/√3), and once the
demand passes N·(1 − t_d/T) the leg goes full-on for a period: 3·t_d/T·V_dc more on that leg,
a current spike, and a relaxation limit cycle (the "cliffs", ``hil/sim/README.md``).

The estimate is the steady state of the motor's dq equations in the twin's frame (q along the
EMF, ``hil.sim.firmware``) plus the fundamental of the dead-time voltage error, (4/π)·V_dc·t_d/T
along the current (a ±V_dc·t_d/T square wave per leg, current-sign dependent). It ignores the
PWM current ripple and the PI's proportional action on it, so near zero headroom the twin may
clip a little earlier or later; a study of how close: ``studies/twin_cliffs.py``.
"""

from __future__ import annotations

import math

from hil.sim.config import DriveConfig


def steady_voltage_v(config: DriveConfig) -> tuple[float, float]:
    """(v_d, v_q) in V that the loop must apply in steady state at ``config``'s operating point:
    v_q = R·i_q − ωe·L·i_d + E + dead-time loss_q, v_d = R·i_d + ωe·L·i_q + dead-time loss_d."""
    motor = config.motor.parameters
    injection = config.injection
    current = config.current_command_a
    i_q = current * math.cos(injection.current_angle_rad)
    i_d = -current * math.sin(injection.current_angle_rad)
    omega_m = config.speed_rpm * 2.0 * math.pi / 60.0
    omega_e = motor.pole_pairs * omega_m
    resistance, inductance = motor.phase_resistance_ohm, motor.phase_inductance_h
    v_q = resistance * i_q - omega_e * inductance * i_d + motor.emf_peak_v_s_per_rad * omega_m
    v_d = resistance * i_d + omega_e * inductance * i_q
    if current > 0.0:
        loss = 4.0 / math.pi * motor.dc_bus_v * injection.dead_time_s * injection.pwm_frequency_hz
        v_q += loss * i_q / current
        v_d += loss * i_d / current
    return v_d, v_q


def peak_leg_duty(config: DriveConfig) -> float:
    """The highest leg duty (per unit of the PWM period) the loop asks for in steady state:
    0.5 + (√3/2)·|v|/V_dc with SVPWM (min-max zero sequence), 0.5 + |v|/V_dc with sine PWM."""
    v_d, v_q = steady_voltage_v(config)
    magnitude = math.hypot(v_d, v_q) / config.motor.parameters.dc_bus_v
    factor = math.sqrt(3.0) / 2.0 if config.inverter.modulation == "svpwm" else 1.0
    return 0.5 + factor * magnitude


def max_leg_duty(config: DriveConfig) -> float:
    """The widest pulse the modulator emits short of full-on: 1 − 2·t_d/T (per unit of T)."""
    injection = config.injection
    return 1.0 - 2.0 * injection.dead_time_s * injection.pwm_frequency_hz


def duty_headroom(config: DriveConfig) -> float:
    """``max_leg_duty − peak_leg_duty``: > 0 inside the twin's linear region, < 0 where the
    highest leg clips (and, further on, the duty-limit limit cycle sets in)."""
    return max_leg_duty(config) - peak_leg_duty(config)
