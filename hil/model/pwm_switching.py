"""PWM switching current ripple and its torque (paper section III-D, eqs 29-31).

Near the zero crossing of a phase voltage (phase b in Fig. 8), the phase sees +V_dc/3 and
−V_dc/3 for equal times. With a centre-aligned carrier the −V_dc/3 state (a high, b and c low)
lasts (d_a − d_b)·T_s/2 per half period, and d_a − d_b = M·[sin(θ + 2π/3) − sin θ] with
M = V_pk/V_dc and θ the angle from the zero crossing of the phase voltage. So eq 31 reads

    ΔT_on = 0.5·M·[sin(θ + 2π/3) − sin θ]·T_s,      0 ≤ θ ≤ 30°

(printed with sin(θ − 2π/3), which would grow from 0° to 30° instead of vanishing at 30° as the
text says), and eq 30, Δi = ΔT_on·(V − i·R − E)/L_s with V = V_dc/3 and i·R + E ≈ 0 at the zero
crossing of the phase voltage, gives the pk-pk current ripple. It is largest at the zero
crossing, √3·V_pk·T_s/(12·L_s), independent of V_dc, and its envelope repeats every 60°: order 6.
The paper takes the per-unit torque ripple equal to this current ripple per unit of I (current in
phase with the EMF); the tests compare that with a switched-circuit torque sum.
"""

from __future__ import annotations

import math

import numpy as np

from hil.model.core import MEAN_TORQUE_BASE, OperatingPoint, Prediction, angle_grid, check_range
from hil.model.pwm_resolution import voltage_phasor

PWM_FREQUENCY_RANGE_HZ = (2000.0, 50000.0)


def on_time_s(angle_from_zero_crossing_rad: np.ndarray, modulation: float,
              period_s: float) -> np.ndarray:
    """Eq 31 (corrected sign): duration of the −V_dc/3 state per half period."""
    theta = np.asarray(angle_from_zero_crossing_rad)
    return 0.5 * modulation * (np.sin(theta + 2 * math.pi / 3) - np.sin(theta)) * period_s


def current_ripple_a(angle_from_zero_crossing_rad: np.ndarray, *, voltage_peak_v: float,
                     dc_bus_v: float, period_s: float, inductance_h: float) -> np.ndarray:
    """Eq 30: pk-pk phase-current ripple Δi = ΔT_on·(V_dc/3)/L_s near a voltage zero crossing."""
    modulation = voltage_peak_v / dc_bus_v
    return on_time_s(angle_from_zero_crossing_rad, modulation, period_s) * dc_bus_v / 3 / inductance_h


def angle_from_zero_crossing(theta: np.ndarray, voltage_angle_rad: float) -> np.ndarray:
    """|distance| in [0, π/6] from the nearest phase-voltage zero crossing (every 60°)."""
    sixth = math.pi / 3
    return np.abs(np.mod(theta + voltage_angle_rad + sixth / 2, sixth) - sixth / 2)


def predict_pwm_switching(op: OperatingPoint, *, pwm_frequency_hz: float = 20000.0) -> Prediction:
    """Switching-frequency current ripple (eqs 29-31) and its order-6 envelope, per unit of I."""
    f_sw = check_range("pwm_frequency_hz", pwm_frequency_hz, *PWM_FREQUENCY_RANGE_HZ, unit=" Hz")
    period = 1.0 / f_sw
    phasor = voltage_phasor(op)
    v_peak = math.sqrt(2.0) * abs(phasor)
    delta = math.atan2(phasor.imag, phasor.real)
    theta = angle_grid()
    envelope = current_ripple_a(angle_from_zero_crossing(theta, delta), voltage_peak_v=v_peak,
                                dc_bus_v=op.dc_bus_v, period_s=period,
                                inductance_h=op.motor.phase_inductance_h) / op.current_a
    peak = float(current_ripple_a(0.0, voltage_peak_v=v_peak, dc_bus_v=op.dc_bus_v,
                                  period_s=period, inductance_h=op.motor.phase_inductance_h))
    return Prediction(
        source="pwm_switching", pk_pk_pu=peak / op.current_a, base=MEAN_TORQUE_BASE,
        base_nm=op.mean_torque_nm, order=6.0,
        inputs={"pwm_frequency_hz": f_sw, "pwm_period_s": period, **op.to_dict()},
        equations="eqs 29-31", assumptions=[
            "centre-aligned carrier; the ripple is the pk-pk within one PWM period",
            "i·R + E cancels the average voltage near the phase-voltage zero crossing",
            "the paper's equivalence: per-unit torque ripple = per-unit phase-current ripple",
            "waveform_pu is the envelope of the switching-frequency ripple (order 6), not the "
            "ripple itself (which is at the switching frequency)"],
        angle_rad=theta, waveform_pu=envelope,
        extras={"current_ripple_pk_pk_a": peak, "voltage_peak_v": v_peak,
                "modulation": v_peak / op.dc_bus_v,
                "switching_order": f_sw / (abs(op.elec_speed_rad_s) / (2 * math.pi))
                if op.speed_rpm else None})
