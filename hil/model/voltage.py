"""The phase voltage a point needs and the voltage the inverter can give (design.md §9).

Steady state of the circuit of paper eqs 1-4 / eq 27 (peak phasors, angle from the q axis, the
direction of the EMF in forward rotation), with the *signed* speed: the drive commands the current
I·e^(−jφ) on its q axis whatever the direction, so

    V = sign(ω)·E + (R + j·ω_e·L)·I·e^(−jφ),    ω_e signed.

In forward rotation that is motoring; in reverse rotation under positive torque the EMF opposes
the drive's voltage and the machine *brakes* (it returns power): the needed |V| is smaller than
the motoring figure of :attr:`hil.model.OperatingPoint.voltage_phasor_peak_v`, which takes |ω|.

The inverter's linear range under SVPWM is a peak phase voltage of V_dc/√3. Dead time takes part
of it: each leg loses ε = T_d·f_pwm·V_dc of its average voltage against the sign of its current
(paper eqs 32-37, averaged over a PWM period), a square wave ±ε per leg whose fundamental has the
peak (4/π)·ε; the common mode it leaves is a triplen and does not reach the phases, so the phase
voltage loses (4/π)·T_d·f_pwm·V_dc along the current's direction. The inverter must therefore
give V + (4/π)·ε·I/|I|.

That loss is a constant ε per leg only while every edge of every leg keeps its dead time inside
the PWM period: a leg's high pulse must end a dead time before the period does (and its low
interval likewise at each end of a centre-aligned period), so the modulator emits no duty above
1 − 2·T_d·f_pwm short of full-on (the simulated firmware, ``hil.sim.validity.max_leg_duty``);
beyond it the leg clips, the edge and its dead-time error vanish and the loop winds up. Under
centre-aligned SVPWM (min-max zero sequence) the highest leg duty is 0.5 + (√3/2)·|V|/V_dc, so
the inverter stays linear with the dead time's error intact while

    |V + loss| ≤ (V_dc/√3)·(1 − 4·T_d·f_pwm)          (:func:`linear_limit_v`).

This is the one limit of the project (the dead-time plan's "edge-keeping" limit and the
pre-flight's headroom were two, 1 − 4·T_d·f and 1 − 2·T_d·f; the latter, "both on-times longer
than T_d", is the bound for a modulator whose low pulses run on across the period boundary, which
the simulated drive's is not). Evidence on the simulated drive (``studies/dead_time_calibration.py``
points refused by it): Table I at 1200 rpm / 10 A, 3 µs needs 5.56 V, inside 1 − 2·T_d·f
(6.10 V) but beyond 1 − 4·T_d·f (5.27 V): the order-6 amplitude read 0.76× the model and order 18
2×; at 4 µs (5.86 V) a correct drive measured 23 % against the model's 2.9 %. Reverse rotation
(braking) needs less: p2_24v at −1089 rpm / 20 A, 3 µs needs 4.57 V against 10.53 V, the model
held (order 6 at 1.00×) where the motoring magnitude (15.1 V) had refused it.

**Current-sensor errors** (injected offsets and gain errors) make the loop regulate what its
sensors read, so the actual current departs from the commanded one by a dc vector (the offsets)
and two rotating ones at ±ω_e (the gain errors: ``sensor_error_current_components_a``); their
voltage, at most R·|ΔI_0| + |R + j·ω_e·L|·(|ΔI_+| + |ΔI_−|), comes on top of the steady phasor.
Found at Table I 1700 rpm / 20 A (6.90 V of 6.93 V): the self-check's transducer-dynamics point
(gain errors ±5 %, ≈ 0.12 V more) saturated the correct drive's loop and read the transducer's
amplitude 0.73 against 0.99 ± 0.13; the point is refused there now.
"""

from __future__ import annotations

import cmath
import math

from hil.model.dead_time import dead_time_voltage_loss_v  # (4/π)·T_d·f_pwm·V_dc, one definition
from hil.motor import MotorParameters


def steady_voltage_phasor_peak_v(motor: MotorParameters, speed_rpm: float, current_a: float,
                                 current_angle_rad: float) -> complex:
    """Peak phase-voltage phasor the drive applies in steady state, V (angle from the forward q
    axis): sign(ω)·E + (R + j·ω_e·L)·I·e^(−jφ) with the signed speed (braking in reverse)."""
    omega_m = speed_rpm * 2.0 * math.pi / 60.0
    omega_e = omega_m * motor.pole_pairs
    emf = motor.emf_peak_v_s_per_rad * omega_m          # signed: −E in reverse rotation
    current = current_a * cmath.exp(-1j * current_angle_rad)
    return emf + complex(motor.phase_resistance_ohm, omega_e * motor.phase_inductance_h) * current


def svpwm_limit_v(dc_bus_v: float) -> float:
    """Largest peak phase voltage of centre-aligned SVPWM without overmodulation: V_dc/√3, V."""
    return dc_bus_v / math.sqrt(3.0)


#: The highest leg duty is 1 − DUTY_DEAD_TIMES·T_d·f_pwm: one dead time at each end of the
#: period (module docstring).
DUTY_DEAD_TIMES = 2.0


def linear_limit_v(dc_bus_v: float, dead_time_s: float = 0.0,
                   pwm_frequency_hz: float = 20_000.0) -> float:
    """Largest peak phase voltage of centre-aligned SVPWM whose every edge keeps its dead time
    within the period, V: (V_dc/√3)·(1 − 4·T_d·f_pwm) (module docstring; V_dc/√3 without dead
    time). ``dead_time_s`` s, ``pwm_frequency_hz`` Hz, ``dc_bus_v`` V."""
    max_duty = 1.0 - DUTY_DEAD_TIMES * dead_time_s * pwm_frequency_hz
    # 0.5 + (√3/2)·|V|/V_dc ≤ max_duty  ⇔  |V| ≤ (V_dc/√3)·(2·max_duty − 1)
    return svpwm_limit_v(dc_bus_v) * max(0.0, 2.0 * max_duty - 1.0)


def inverter_voltage_needed_v(motor: MotorParameters, speed_rpm: float, current_a: float,
                              current_angle_rad: float, dead_time_s: float = 0.0,
                              pwm_frequency_hz: float = 20_000.0,
                              sensor_errors: dict | None = None) -> float:
    """Peak phase voltage the inverter must produce, V: the steady phasor plus the dead time's
    loss along the current, |V + (4/π)·T_d·f_pwm·V_dc·e^(−jφ)|, plus the voltage of the
    current the ``sensor_errors`` (``ia_offset_a``, ``ib_offset_a``, ``ia_gain_error_pu``,
    ``ib_gain_error_pu``) make the loop drive (module docstring)."""
    phasor = steady_voltage_phasor_peak_v(motor, speed_rpm, current_a, current_angle_rad)
    loss = dead_time_voltage_loss_v(dead_time_s, pwm_frequency_hz, motor.dc_bus_v)
    if current_a > 0:
        phasor += loss * cmath.exp(-1j * current_angle_rad)
    extra = 0.0
    if sensor_errors:
        dc, forward, backward = sensor_error_current_components_a(current_a, **sensor_errors)
        omega_e = speed_rpm * 2.0 * math.pi / 60.0 * motor.pole_pairs
        impedance = abs(complex(motor.phase_resistance_ohm, omega_e * motor.phase_inductance_h))
        extra = motor.phase_resistance_ohm * dc + impedance * (forward + backward)
    return abs(phasor) + extra


def sensor_error_current_components_a(current_a: float, *, ia_offset_a: float = 0.0,
                                      ib_offset_a: float = 0.0, ia_gain_error_pu: float = 0.0,
                                      ib_gain_error_pu: float = 0.0) -> tuple[float, float, float]:
    """(|ΔI_0|, |ΔI_+|, |ΔI_−|), A peak: the dc, forward and backward space vectors of the actual
    current's departure from the commanded one when the loop makes phases a and b *read* the
    command (read = (1 + g)·i + offset; c = −a − b), over one electrical revolution. Exact for a
    loop that tracks the reading (one that tracks less drives less of it: an upper bound)."""
    theta = [2.0 * math.pi * k / 64 for k in range(64)]
    vectors = []
    for angle in theta:
        ref_a = current_a * math.cos(angle)
        ref_b = current_a * math.cos(angle - 2.0 * math.pi / 3.0)
        delta_a = (ref_a - ia_offset_a) / (1.0 + ia_gain_error_pu) - ref_a
        delta_b = (ref_b - ib_offset_a) / (1.0 + ib_gain_error_pu) - ref_b
        delta_c = -delta_a - delta_b
        vectors.append((2.0 / 3.0) * (delta_a + delta_b * cmath.exp(2j * math.pi / 3.0)
                                      + delta_c * cmath.exp(-2j * math.pi / 3.0)))
    def component(order: int) -> float:
        return abs(sum(v * cmath.exp(-1j * order * a) for v, a in zip(vectors, theta)) / 64)
    return component(0), component(1), component(-1)
