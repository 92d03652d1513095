"""The drive's current loop as the models see it: one place for the stated designs' equations.

A bench file states the loop (``[drive] current_loop_design``, ``current_loop_bandwidth_hz``,
``current_loop_delay_s``, ``current_loop_angle_compensation``); the models that reject a voltage
disturbance through it (the dead time's, ``hil.model.dead_time``) take its gains from
:func:`loop_gains` and its disturbance transfer from :func:`disturbance_response`; the models
that represent a PI only (PWM resolution, word length) take the PI of the same integral action,
:func:`pi_equivalent_bandwidth_hz`, and refuse a design they lack (``hil.validity``).

Every design is written in one form, in the rotor frame with complex vectors (x = x_d + j·x_q,
the frame turning at the signed electrical speed ω_e; plant P(s) = 1/(R + L·(s + jω_e)), s the
rotor-frame frequency), with e = i_ref − i the current error and u the computed voltage::

    u = K_p·e + z,     dz/dt = K_i·e + K_r·(u_a − u)

where u_a is the voltage the inverter applies now (the computed one, τ = ``delay_s`` later, at
the angle it was computed for, or with ``angle_compensation`` advanced by ω_e·τ so that it lands
on the rotor angle it was meant for). In the frequency domain u_a = D·u with D = e^{−sτ}
(angle compensation) or e^{−(s + jω_e)·τ} (none), hence the controller

    C(s) = (K_p·s + K_i) / (s + K_r·(1 − D)),      i = P·d / (1 + C·D·P)

for a voltage disturbance d (the dead time's), the integrator rejecting a constant d
completely where it integrates (not a realised-voltage integrator without angle compensation,
which sees u_a ≠ u in steady state). The designs:

* ``"continuous"`` — the PI designed in s: K_p = ω_c·L, K_i = ω_c·R, K_r = 0 (pole-zero
  cancellation, closed loop ω_c/(s + ω_c) without delay); per axis, no cross term.
* ``"discrete"`` — the pole-matched PI in z (``hil.sim``'s twin: zero at e^{−R·T_s/L}, delay-free
  closed-loop pole at e^{−ω_c·T_s}) represented by the continuous PI of the same integral gain,
  at :func:`pi_equivalent_bandwidth_hz` (the twin's order-6 dead-time ripple within 3 %,
  ``tests/sim/test_current_loop.py``).
* ``"2dof"`` — the synchronous-frame complex-vector 2-DOF PI of Briz, Degner, Lorenz, "Analysis
  and design of current regulators using complex vectors", IEEE TIA 2000, tuned as in Awan,
  Saarakkala, Hinkkanen, "Flux-linkage-based current control of saturated synchronous motors",
  IEEE TIA 2019 (motulator's ``ComplexPIController`` with k_t = α_c, k_p = 2·α_c, k_i = α_c² on
  the flux linkage ψ = L·i):
  u = k_t·L·i_ref − k_p·L·i + (k_i + jω_e·k_t)·L/s·(i_ref − i), whose integrator is updated
  from the *realised* voltage (anti-windup on the realised output, u_i' = (α_c + jω_e)·(u_a − v)
  with v the disturbance estimate): K_p = 2·α_c·L, K_i = (α_c + jω_e)·α_c·L, K_r = α_c + jω_e,
  α_c = 2π·``bandwidth_hz``. Its reference tracking is α_c/(s + α_c) without delay; its
  integral action α_c²·L (against ω_c·R of the PI: 4.4× at Table I and 1 kHz, 15.7× on the
  8-pole 48 V motor) and doubled proportional gain reject a voltage disturbance far more: at
  order 6 on motulator's drive the current per volt is 0.33-0.45 of the PI's (issue 30,
  ``hil/model/README.md``). Fed from the computed voltage instead (K_r = 0) it is another
  design: at −800 rpm on the 8-pole motor its order-6 response is 21 % below the realised
  form's — a bench file's "2dof" is the realised form (motulator's, documented there).

Decoupling of the cross terms and the back-EMF feed-forward are not in this form (the dead-time
model neglects them, as before); ``hil.diagnosis.signatures`` takes the continuous and 2-DOF
designs from here and adds decoupling and the exact z-domain discrete PI itself.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hil.errors import InputError

#: The designs a bench file can state (``[drive] current_loop_design``; module docstring).
LOOP_DESIGNS = ("continuous", "discrete", "2dof")
#: The designs a PI-only model represents (the discrete one by its equivalent bandwidth).
PI_DESIGNS = ("continuous", "discrete")


@dataclass(frozen=True)
class LoopGains:
    """One design's gains in the module's form u = K_p·e + z, dz/dt = K_i·e + K_r·(u_a − u)."""

    #: K_p, V/A
    proportional_v_per_a: float
    #: K_i, V/(A·s)
    integral_v_per_a_s: complex
    #: K_r, 1/s: the integrator's feedback of the applied minus the computed voltage
    realised_feedback_per_s: complex = 0j


def check_design(design: str) -> str:
    if design not in LOOP_DESIGNS:
        raise InputError(f"current_loop_design={design!r} is not one of "
                         f"{', '.join(LOOP_DESIGNS)}")
    return design


def pi_equivalent_bandwidth_hz(design: str, bandwidth_hz: float | None,
                               pwm_frequency_hz: float = 20_000.0) -> float | None:
    """Bandwidth (Hz) of the continuous PI (K_p = L·ω_c, K_i = R·ω_c) with the stated loop's
    integral gain: the stated one for ``"continuous"``; f_pwm·(1 − e^{−2π·bw/f_pwm})/(2π) for
    the pole-matched ``"discrete"`` design (its K_i = R·(1 − e^{−ω_c·T_s})/T_s). ``"2dof"``
    has no such PI (its integral gain α_c²·L holds no R): InputError. None when the bandwidth is
    not stated."""
    check_design(design)
    if bandwidth_hz is None or design == "continuous":
        return bandwidth_hz
    if design == "2dof":
        raise InputError("a '2dof' current loop has no equivalent PI (its integral gain is "
                         "α_c²·L, not R·ω_c): a PI-only model cannot represent it")
    return -pwm_frequency_hz * math.expm1(-2.0 * math.pi * bandwidth_hz / pwm_frequency_hz) \
        / (2.0 * math.pi)


def loop_gains(design: str, bandwidth_hz: float, *, resistance_ohm: float, inductance_h: float,
               elec_speed_rad_s: float, pwm_frequency_hz: float = 20_000.0) -> LoopGains:
    """The gains of ``design`` at ``bandwidth_hz`` (Hz), designed with the R (Ω) and L (H)
    given (the drive's tuning), at the signed electrical speed (rad/s) (module docstring)."""
    if design == "2dof":
        alpha = 2.0 * math.pi * bandwidth_hz
        feedback = complex(alpha, elec_speed_rad_s)
        return LoopGains(proportional_v_per_a=2.0 * alpha * inductance_h,
                         integral_v_per_a_s=feedback * alpha * inductance_h,
                         realised_feedback_per_s=feedback)
    return pi_gains(2.0 * math.pi * pi_equivalent_bandwidth_hz(design, bandwidth_hz,
                                                                pwm_frequency_hz),
                    resistance_ohm=resistance_ohm, inductance_h=inductance_h)


def pi_gains(bandwidth_rad_s: float, *, resistance_ohm: float, inductance_h: float) -> LoopGains:
    """The continuous-design PI K_p = ω_c·L, K_i = ω_c·R (ω_c in rad/s; 0: no loop gains)."""
    return LoopGains(proportional_v_per_a=bandwidth_rad_s * inductance_h,
                     integral_v_per_a_s=complex(bandwidth_rad_s * resistance_ohm))


def applied_delay(rotor_frequency_rad_s, elec_speed_rad_s: float, delay_s: float,
                  angle_compensation: bool):
    """D: the applied voltage per computed voltage in the rotor frame (module docstring)."""
    s = 1j * np.asarray(rotor_frequency_rad_s, dtype=float)
    rotation = 0.0 if angle_compensation else 1j * elec_speed_rad_s
    return np.exp(-(s + rotation) * delay_s)


def disturbance_response(rotor_frequency_rad_s, *, resistance_ohm: float, inductance_h: float,
                         elec_speed_rad_s: float, gains: LoopGains | None, delay_s: float = 0.0,
                         angle_compensation: bool = False):
    """Voltage disturbance → current (A/V) in the rotor frame at rotor-frame frequencies ω
    (rad/s; a number gives a complex, an array an array): P/(1 + C·D·P) with the plant's R (Ω)
    and L (H); ``gains`` None: no loop (voltage-fed, P). 0 where the controller integrates
    (ω = 0 with K_r·(1 − D) = 0: its integrator rejects a constant disturbance completely;
    a realised-voltage integrator without angle compensation does not)."""
    w = np.asarray(rotor_frequency_rad_s, dtype=float)
    s = 1j * w
    plant = 1.0 / (resistance_ohm + inductance_h * (s + 1j * elec_speed_rad_s))
    if gains is not None:
        delay = applied_delay(w, elec_speed_rad_s, delay_s, angle_compensation)
        denominator = controller_denominator(gains, w, delay)
        integrating = denominator == 0.0
        controller = ((gains.proportional_v_per_a * s + gains.integral_v_per_a_s)
                      / np.where(integrating, 1.0, denominator))
        plant = np.where(integrating, 0j, plant / (1.0 + controller * delay * plant))
    return complex(plant) if plant.ndim == 0 else plant


def controller_denominator(gains: LoopGains, rotor_frequency_rad_s, delay):
    """s + K_r·(1 − D) at rotor-frame frequencies ω (rad/s), D the applied-voltage factor
    there (:func:`applied_delay`): C's denominator, 0 where the controller integrates."""
    s = 1j * np.asarray(rotor_frequency_rad_s, dtype=float)
    return s + gains.realised_feedback_per_s * (1.0 - delay)


def controller_response(gains: LoopGains, rotor_frequency_rad_s, delay):
    """C(s) = (K_p·s + K_i)/(s + K_r·(1 − D)) (V/A) at rotor-frame frequencies ω (rad/s) where
    the controller does not integrate, ``delay`` the applied-voltage factor D there
    (:func:`applied_delay`; module docstring)."""
    s = 1j * np.asarray(rotor_frequency_rad_s, dtype=float)
    return ((gains.proportional_v_per_a * s + gains.integral_v_per_a_s)
            / controller_denominator(gains, rotor_frequency_rad_s, delay))
