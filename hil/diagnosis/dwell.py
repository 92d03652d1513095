"""A stated bound for the torque of the dead-time voltage during a coarse encoder's dwells.

With a coarse encoder the current command is the paper's staircase (eq 4 with the truncated angle
θ_d, Fig. 2): for one count after each zero crossing of a phase's command (θ_d − φ − o_x a
multiple of π, with φ = 0 and a count aligned with θ_e = 0) the command *is* zero, and the phase
current sits for a whole count at the level the loop leaves it (−T·offset plus the PWM ripple),
inside the transition of the dead-time characteristic (eqs 32-38: the leg's voltage is set by its
current's direction, and a current near zero clamps). The average-voltage model of
``hil.model.dead_time`` (a continuous command, −ε·sign(i) everywhere defined) does not describe
that interval: there the leg's average dead-time error is some value in [−ε, ε], ε = T_d·f_pwm·V_dc
(the average loss per leg), set by the offset, the ripple and the clamp. Two dwells of one phase
no longer cancel (the half-wave symmetry is lost), so the error has a dc and even harmonics, i.e.
an order-1 torque (and order 2, 3) that the sensor offsets would absorb.

No closed form for the dwell value is derived here (it needs the ripple at the switching instants
and the clamp). It is *bounded*: each dwell (3 legs × 2 crossings) carries an unknown error
a ∈ [−ε, ε]; the dwell current (−T·o_x; +T·(o_a + o_b) for the computed phase c) has a sign,
which sets the leg voltage (eqs 32-37), so a is taken at a bound, ±ε (two-point, standard
uncertainty ε). The current enters a dwell from the other side when the rotation reverses, so
each direction has its own 6 unknowns, each the same at every operating point of that direction
(the offset and ε are). Each dwell's torque goes through the same loop and torque map as every
other signature (:func:`dwell_pulse_orders`) and is propagated through the estimator as a
systematic term (:class:`hil.diagnosis.fit.SystematicTerm`; assembled in
``hil.diagnosis.core._dwell_terms``). ε needs the dead time, which a coarse encoder hides: the
drive's stated upper bound (``DriveSetup.dead_time_bound_s``) when given, else the nuisance
estimate × (1 + 2 × its 100 % model uncertainty), stated as weaker (the average model reads low
with a coarse encoder). On the twin the bound covers the offsets' errors with mean |err|/U ≈ 0.2
(conservative); its voltage-through-the-loop picture does not reproduce the speed dependence of
the observed dc shifts (README, "Proof on the twin").
"""

from __future__ import annotations

import math

import numpy as np

from hil.diagnosis import signatures as sig

#: Electrical grid for the pulse waveforms (fine enough for a count of a few degrees).
PULSE_GRID_POINTS = 2048
#: Space-vector factor of a dc voltage in one leg (isolated neutral: the phase voltages are the
#: leg's minus the legs' mean): leg a → 2/3; b and c rotated by ∓120° (the signatures' Clarke
#: convention, v_α = v_a, v_β = (v_a + 2·v_b)/√3).
LEG_VECTOR = {"a": 2.0 / 3.0, "b": complex(-1.0 / 3.0, 1.0 / math.sqrt(3.0)),
              "c": complex(-1.0 / 3.0, -1.0 / math.sqrt(3.0))}
#: Angle (rad) of each phase's command, eq 4: i_x = I·sin(θ − φ − o_x).
LEG_ANGLE_RAD = {"a": 0.0, "b": 2.0 * math.pi / 3.0, "c": 4.0 * math.pi / 3.0}


def leg_loss_v(dead_time_s: float, pwm_frequency_hz: float, dc_bus_v: float) -> float:
    """ε = T_d·f_pwm·V_dc (V): the average voltage a leg loses to the dead time (the average
    model of eqs 32-38); the bound of a dwell's leg-voltage error."""
    return max(dead_time_s, 0.0) * pwm_frequency_hz * dc_bus_v


def dwell_starts_rad(op, leg: str, resolution_rad: float) -> tuple[float, float]:
    """Start angles (rad) of the two dwells of ``leg``: one count from each zero crossing of its
    command (the model spectra's φ already carries the half-count lag of the truncated angle,
    so the count that follows a crossing starts half a count before the model's crossing)."""
    start = op.current_angle_rad - resolution_rad / 2.0 + LEG_ANGLE_RAD[leg]
    return start, start + math.pi


def dwell_pulse_orders(op, setup: sig.DriveSetup, leg: str, start_rad: float,
                       width_rad: float) -> tuple[np.ndarray, complex]:
    """Per volt of average error in ``leg`` during the dwell [start, start + width), electrical-order
    torque coefficients (N·m) and the dc of the actual phase currents as dc_a + j·dc_b (A). The
    pulse's harmonics e^{jmθ} are seen by the loop at (m − 1)·ω_e (loop_disturbance with the
    bench's loop design; its synchronous-frame integrator does not remove a stationary dc), and
    the current error enters the torque sum of eq 7 as every signature's does."""
    n = PULSE_GRID_POINTS
    m = np.fft.fftfreq(n, 1.0 / n)
    safe = np.where(m == 0, 1.0, m)
    # Fourier coefficients of the unit pulse, exact (not sampled)
    c = np.where(m == 0, width_rad / (2 * math.pi),
                 (np.exp(-1j * safe * start_rad) - np.exp(-1j * safe * (start_rad + width_rad)))
                 / (2j * math.pi * safe))
    rejection = sig.loop_disturbance((m - 1.0) * op.elec_speed_rad_s, op, setup)
    current = np.fft.ifft(c * LEG_VECTOR[leg] * rejection) * n
    theta = sig.electrical_grid(n)
    k_e = op.motor.emf_peak_v_s_per_rad
    torque = 1.5 * k_e * np.real(-1j * np.exp(1j * theta) * np.conj(current))
    dc = complex(np.mean(current))
    return (sig.waveform_orders(torque),
            complex(dc.real, -0.5 * dc.real + 0.5 * math.sqrt(3.0) * dc.imag))
