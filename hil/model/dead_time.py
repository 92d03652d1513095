"""Inverter dead time (paper section III-D, eqs 32-38) and a physically derived alternative.

Paper model ("paper"): while a phase current is clamped at zero its terminal voltage is lost; the
stationary-frame voltage error along that phase's axis is v* = (2/3)·V_dc for T_d (eqs 32-37), and
eq 38 gives a current step Δi_q ≈ v*·T_d/L_s. The paper takes the pk-pk torque ripple as
Δi_q / I_nom (order 6). Its "2 µs → 2 %" for Table I ((2/3)·12 V·2 µs/38.5 µH = 0.416 A) is
reproduced with a nominal current I_nom = 20.8 A peak (≈ 1.0 N·m); ``nominal_current_a`` defaults
to the operating point's current. Note eq 38 is a per-event current step, not a steady ripple,
and a step along the axis of a phase whose current is crossing zero is orthogonal to the EMF
when φ = 0: it is the torque of that step only if it were aligned with the EMF.

Average-voltage model ("average_voltage"): each leg loses ε = T_d·f_sw·V_dc of its average voltage
against its current, Δv_x = −ε·sign(i_x). Without the common mode this is a six-step wave with
harmonics n = 6k ± 1 of amplitude 4ε/(π·n). Each drives the motor impedance R + j·n·ω_e·L_s; the
stated current loop (``hil.current_loop``: ``current_loop_design`` "continuous" — the
synchronous-frame PI Kp = ω_c·L_s, Ki = ω_c·R, no decoupling —, "discrete" or "2dof", the
complex-vector 2-DOF PI) rejects the disturbance, current per volt P/(1 + C·D·P) evaluated at the
rotor-frame frequency ((n − 1)·ω_e for the positive sequence n = 6k + 1, −(n + 1)·ω_e for the
negative sequence n = 6k − 1). The loop delay τ (``current_loop_delay_s``; e.g. 1.5 PWM periods:
one of computation, half of PWM hold) enters as D = e^{−(s + jω_e)·τ} — the voltage is applied τ
later at the angle it was computed for — or, with ``current_loop_angle_compensation``, e^{−sτ}.
The harmonic currents in the torque sum Σ e_x·i_x/ω_m give order-6 ripple; the series is summed
to n = 601.

Current-clamping model ("current_clamping", the one the dead-time plan judges against): the same
average voltage error, but with the sign of the *actual* current, solved in the time domain to its
periodic steady state (``hil.model.dead_time_steady_state``). Near each zero crossing the error
flips with the current and the current dwells at zero; where ε is not small against the phase
voltage (low speed, low current) this adds order-12, 18, … content the six-step series misses
(the six-step series was 20–35 % low in pk-pk at 250 rpm / 10 A and 500 rpm / 10 A against the
simulated drive: ``studies/dead_time_calibration.py``). The PWM current ripple is included where
it matters, at the zero crossings: a leg's error is set by the current at its two edges of the
period, which differ from the period average by ∓a_x (the ripple's excursion); while |i_x| < a_x
the two edges see opposite signs and their errors cancel, and a dead interval that starts near
zero clamps the current there (``dead_time_steady_state``). At low current on a low-inductance
motor this is a large part of the crossing: Table I at 1000 rpm / 5 A, 2 µs, a_x ≈ 0.64 A of
5 A; without it the model read 30 % low there (0.0277 pu against 0.0367 measured). The orders kept are 1..``max_order`` (the
analysis's band); with ``transducer_bandwidth_hz`` each order k is multiplied by the stated
first-order transducer response at k·f_e, as the bench measures it (its phase enters the order-6
phase the plan judges).

``dead_time_voltage_loss_v`` gives the fundamental of the leg error, the phase voltage the dead
time costs (for the pre-flight voltage headroom, ``hil.model.voltage``, where the one linear
limit with dead time, (V_dc/√3)·(1 − 4·T_d·f_sw), is derived).
"""

from __future__ import annotations

import math

import numpy as np

from hil.current_loop import (LOOP_DESIGNS, LoopGains, check_design, disturbance_response,
                              loop_gains)
from hil.errors import InputError
from hil.model.core import (MEAN_TORQUE_BASE, PHASE_OFFSETS_RAD, OperatingPoint, Prediction,
                            angle_grid, check_range)

DEAD_TIME_RANGE_S = (0.0, 10e-6)
#: The stated loop designs the models here represent (``hil.validity`` refuses the others).
REPRESENTED_LOOP_DESIGNS = LOOP_DESIGNS
#: Nominal current that reproduces the paper's "2 µs → 2 %" with Table I (see module docstring).
PAPER_NOMINAL_CURRENT_A = (2.0 / 3.0) * 12.0 * 2e-6 / 38.5e-6 / 0.02
MODELS = ("paper", "average_voltage", "current_clamping")
#: orders the current-clamping waveform keeps: the band the plans analyse (PointPlan.max_order)
CLAMPING_MAX_ORDER = 48
HIGHEST_HARMONIC = 601


def dead_time_voltage_loss_v(dead_time_s: float, pwm_frequency_hz: float,
                             dc_bus_v: float) -> float:
    """Peak phase voltage (V) of the fundamental the dead time takes away, directed against the
    phase current.

    Each leg loses ε = T_d·f_sw·V_dc (V) of its per-PWM-period average voltage against its current
    (the average form of the paper's eqs 32-37); without the common mode that is a six-step phase
    wave whose fundamental has amplitude (4/π)·ε. ``dead_time_s`` the inverter's dead time (s),
    ``pwm_frequency_hz`` the PWM (switching) frequency (Hz), ``dc_bus_v`` the dc bus (V).
    Example: 1 µs, 20 kHz, 12 V → 0.306 V. Near zero current the loss is smaller (the clamping of
    the current at zero), so this is the bound a voltage-headroom check should use.
    """
    t_d = check_range("dead_time_s", dead_time_s, *DEAD_TIME_RANGE_S, unit=" s")
    f_sw = check_range("pwm_frequency_hz", pwm_frequency_hz, 0.0, 1e6, unit=" Hz")
    v_dc = check_range("dc_bus_v", dc_bus_v, 0.0, 2000.0, unit=" V")
    return 4.0 / math.pi * t_d * f_sw * v_dc


def transducer_response(frequency_hz, bandwidth_hz: float | None):
    """Stated first-order transducer response at a signed frequency (Hz): 1/(1 + j·f/f_t).

    A negative frequency (reverse rotation) gives the conjugate, i.e. the same lag in time.
    """
    f = np.asarray(frequency_hz, dtype=float)
    if not bandwidth_hz:
        return np.ones_like(f, dtype=complex)
    return 1.0 / (1.0 + 1j * f / bandwidth_hz)


def paper_current_step_a(dead_time_s: float, dc_bus_v: float, inductance_h: float) -> float:
    """Eq 38: Δi_q ≈ v*·T_d/L_s with v* = (2/3)·V_dc."""
    return (2.0 / 3.0) * dc_bus_v * dead_time_s / inductance_h


def stated_loop_gains(op: OperatingPoint, design: str, bandwidth_hz: float | None,
                      pwm_frequency_hz: float = 20_000.0) -> LoopGains | None:
    """The stated loop's gains (``hil.current_loop``), designed with the R and L of
    ``op.loop_motor`` (the plant's by default); None without a bandwidth (no loop)."""
    if not bandwidth_hz:
        return None
    tuned = op.loop_motor
    return loop_gains(design, bandwidth_hz, resistance_ohm=tuned.phase_resistance_ohm,
                      inductance_h=tuned.phase_inductance_h,
                      elec_speed_rad_s=op.elec_speed_rad_s, pwm_frequency_hz=pwm_frequency_hz)


def loop_rejection(rotor_frequency_rad_s, op: OperatingPoint,
                   bandwidth_rad_s: float | None, delay_s: float = 0.0, *,
                   gains: LoopGains | None = None, angle_compensation: bool = False):
    """Disturbance voltage → current of the motor in the rotor frame, with the loop if any
    (``hil.current_loop.disturbance_response``): ``gains``, else the continuous PI at
    ``bandwidth_rad_s`` (rad/s) designed with ``op.loop_motor``'s R and L; neither: voltage-fed.

    ``rotor_frequency_rad_s`` a number (returns a complex) or an array (returns an array).
    """
    if gains is None and bandwidth_rad_s:
        gains = stated_loop_gains(op, "continuous", bandwidth_rad_s / (2.0 * math.pi))
    motor = op.motor
    return disturbance_response(
        rotor_frequency_rad_s, resistance_ohm=motor.phase_resistance_ohm,
        inductance_h=motor.phase_inductance_h, elec_speed_rad_s=op.elec_speed_rad_s,
        gains=gains, delay_s=delay_s, angle_compensation=angle_compensation)


def average_model_torque_pu(theta: np.ndarray, op: OperatingPoint, dead_time_s: float,
                            pwm_frequency_hz: float,
                            current_loop_bandwidth_hz: float | None,
                            current_loop_delay_s: float = 0.0, *,
                            rejection=None, current_loop_design: str = "continuous",
                            current_loop_angle_compensation: bool = False) -> np.ndarray:
    """Torque per unit of (3/2)·E·I·cos φ/ω_m at electrical angles θ, average dead-time model.

    ``rejection``: optional callable, rotor-frame frequencies (rad/s, array) → disturbance
    voltage → current transfer (A/V) of another loop (hil.diagnosis.signatures
    .loop_disturbance); default :func:`loop_rejection` with the stated design, bandwidth (Hz),
    delay (s) and angle compensation.
    """
    omega = op.elec_speed_rad_s
    eps = dead_time_s * pwm_frequency_hz * op.dc_bus_v
    if rejection is None:
        gains = stated_loop_gains(op, current_loop_design, current_loop_bandwidth_hz,
                                  pwm_frequency_hz)

        def rejection(w):
            return loop_rejection(w, op, None, current_loop_delay_s, gains=gains,
                                  angle_compensation=current_loop_angle_compensation)
    harmonics = np.array([n for n in range(1, HIGHEST_HARMONIC + 1, 2) if n % 3 != 0])
    positive = harmonics % 6 == 1
    # positive sequence n = 6k + 1 at (n − 1)·ω_e; negative n = 6k − 1 at −(n + 1)·ω_e, conj.
    frequencies = np.where(positive, (harmonics - 1) * omega, -(harmonics + 1) * omega)
    gains = np.asarray(rejection(frequencies.astype(float)), dtype=complex)
    gains = np.where(positive, gains, np.conj(gains))
    # Δv_x harmonic n: −ε·(4/(πn))·sin(n(ψ − o_x)) = Re(j·ε·(4/(πn))·e^{jn(ψ − o_x)})
    amplitudes = 1j * eps * 4.0 / (math.pi * harmonics) * gains
    size = theta.size
    uniform = (size > 2 * HIGHEST_HARMONIC and theta[0] == 0.0
               and np.allclose(np.diff(theta), 2 * math.pi / size, rtol=0, atol=1e-12))
    delta_i = np.zeros((3, size))
    for x, offset in enumerate(PHASE_OFFSETS_RAD):
        coefficients = amplitudes * np.exp(-1j * harmonics * (op.current_angle_rad + offset))
        if uniform:     # θ_k = 2πk/N: the sum over n is an inverse DFT (same value, fast)
            line = np.zeros(size, dtype=complex)
            line[harmonics] = coefficients
            delta_i[x] = np.real(np.fft.ifft(line) * size)
        else:
            delta_i[x] = np.real(np.exp(1j * np.outer(theta, harmonics)) @ coefficients)
    emf_shape = np.sin(theta[None, :] - PHASE_OFFSETS_RAD[:, None])  # e_x / E
    ideal = 1.5 * math.cos(op.current_angle_rad)
    return (ideal + np.sum(emf_shape * delta_i, axis=0) / op.current_a) / ideal


def predict_dead_time(op: OperatingPoint, *, dead_time_s: float,
                      nominal_current_a: float | None = None, model: str = "paper",
                      pwm_frequency_hz: float = 20000.0,
                      current_loop_bandwidth_hz: float | None = None,
                      current_loop_delay_s: float = 0.0,
                      transducer_bandwidth_hz: float | None = None,
                      current_loop_design: str = "continuous",
                      current_loop_angle_compensation: bool = False) -> Prediction:
    """Order-6 dead-time ripple: the paper's eq 38, the average-voltage-error series, or that
    error with the actual current's sign (``current_clamping``, module docstring). The loop:
    ``current_loop_design`` at ``current_loop_bandwidth_hz`` (Hz), ``current_loop_delay_s`` (s)
    and ``current_loop_angle_compensation``, as ``hil.current_loop`` writes them."""
    t_d = check_range("dead_time_s", dead_time_s, *DEAD_TIME_RANGE_S, unit=" s")
    if model not in MODELS:
        raise InputError(f"model={model!r} is not one of {', '.join(MODELS)}")
    nominal = check_range("nominal_current_a", nominal_current_a or op.current_a, 0.0, 100.0,
                          unit=" A", low_open=True)
    f_sw = check_range("pwm_frequency_hz", pwm_frequency_hz, 2000.0, 50000.0, unit=" Hz")
    if current_loop_bandwidth_hz is not None:
        check_range("current_loop_bandwidth_hz", current_loop_bandwidth_hz, 0.0, 0.5 * f_sw,
                    unit=" Hz")
    delay = check_range("current_loop_delay_s", current_loop_delay_s, 0.0, 1e-3, unit=" s")
    loop = {"design": check_design(current_loop_design),
            "angle_compensation": bool(current_loop_angle_compensation)}
    if transducer_bandwidth_hz is not None:
        check_range("transducer_bandwidth_hz", transducer_bandwidth_hz, 0.0, 1e6, unit=" Hz",
                    low_open=True)
    step = paper_current_step_a(t_d, op.dc_bus_v, op.motor.phase_inductance_h)
    inputs = {"dead_time_s": t_d, "nominal_current_a": nominal, "model": model,
              "pwm_frequency_hz": f_sw, "current_loop_bandwidth_hz": current_loop_bandwidth_hz,
              "current_loop_delay_s": delay, "transducer_bandwidth_hz": transducer_bandwidth_hz,
              "current_loop_design": loop["design"],
              "current_loop_angle_compensation": loop["angle_compensation"], **op.to_dict()}
    paper_pu = step / nominal
    if model == "paper":
        return Prediction(
            source="dead_time", pk_pk_pu=paper_pu,
            base=f"torque at the nominal current I_nom = {nominal:g} A (eq 38: Δi_q/I_nom)",
            base_nm=op.motor.torque_constant_nm_per_a * nominal, order=6.0, inputs=inputs,
            equations="eqs 32-38", assumptions=[
                "per-event current step of a (2/3)·V_dc error lasting T_d, resistance neglected",
                "torque ripple per unit = Δi_q / I_nom (the step taken as aligned with the EMF)"],
            extras={"current_step_a": step})
    if op.speed_rpm == 0.0:
        raise InputError("speed_rpm=0: the average-voltage form has no harmonics at standstill "
                         "(allowed: speed_rpm != 0 with model=average_voltage)")
    if model == "current_clamping":
        return _clamping_prediction(op, t_d, f_sw, current_loop_bandwidth_hz, delay, loop,
                                    transducer_bandwidth_hz, inputs, paper_pu, step)
    theta = angle_grid()
    torque = average_model_torque_pu(theta, op, t_d, f_sw, current_loop_bandwidth_hz, delay,
                                     current_loop_design=loop["design"],
                                     current_loop_angle_compensation=loop["angle_compensation"])
    mean = float(np.mean(torque))
    waveform = (torque - mean) / mean
    return Prediction(
        source="dead_time", pk_pk_pu=float(np.ptp(waveform)), base=MEAN_TORQUE_BASE + " with the "
        "dead-time fundamental included", base_nm=op.mean_torque_nm * mean, order=6.0,
        inputs=inputs, equations="average voltage error T_d·f_sw·V_dc per leg (not in the paper)",
        assumptions=[
            "current direction taken from the ideal sinusoidal currents",
            "average (per-PWM-period) voltage error, no zero-current clamping",
            loop_assumption(loop, current_loop_bandwidth_hz, delay)],
        angle_rad=theta, waveform_pu=waveform,
        extras={"paper_pk_pk_pu": paper_pu, "current_step_a": step,
                "leg_voltage_error_v": t_d * f_sw * op.dc_bus_v})


def loop_assumption(loop: dict, bandwidth_hz: float | None, delay_s: float) -> str:
    """The stated loop as the prediction's assumption, in words."""
    if not bandwidth_hz:
        return "no current loop (voltage-fed, open loop)"
    form = {"continuous": "synchronous-frame PI, Kp = ω_c·L_s, Ki = ω_c·R",
            "discrete": "pole-matched discrete PI as the continuous PI of its integral gain",
            "2dof": "complex-vector 2-DOF PI, K_p = 2α_c·L, K_i = (α_c + jω_e)·α_c·L, its "
                    "integrator fed from the applied voltage"}[loop["design"]]
    return (f"{form} ({bandwidth_hz:g} Hz), no decoupling, delay {delay_s:.3g} s"
            f"{' with angle compensation' if loop['angle_compensation'] else ''}, "
            "continuous-time (no sampling)")


def _clamping_prediction(op: OperatingPoint, t_d: float, f_sw: float,
                         bandwidth_hz: float | None, delay_s: float, loop: dict,
                         transducer_bandwidth_hz: float | None, inputs: dict, paper_pu: float,
                         step: float) -> Prediction:
    """The current-clamping model's prediction (module docstring)."""
    from hil.model.dead_time_steady_state import steady_state_torque_orders

    motor = op.motor
    eps = t_d * f_sw * op.dc_bus_v
    speed_sign = 1.0 if op.speed_rpm > 0 else -1.0
    coefficients = steady_state_torque_orders(
        resistance_ohm=motor.phase_resistance_ohm, inductance_h=motor.phase_inductance_h,
        emf_peak_v=speed_sign * op.emf_peak_v, elec_speed_rad_s=op.elec_speed_rad_s,
        current_a=op.current_a, current_angle_rad=op.current_angle_rad, leg_error_v=eps,
        loop_bandwidth_rad_s=2 * math.pi * bandwidth_hz if bandwidth_hz else 0.0,
        delay_s=delay_s, max_order=CLAMPING_MAX_ORDER,
        dc_bus_v=op.dc_bus_v, pwm_frequency_hz=f_sw,
        loop_gains=stated_loop_gains(op, loop["design"], bandwidth_hz, f_sw),
        angle_compensation=loop["angle_compensation"])
    orders = np.arange(coefficients.size)
    elec_hz = op.elec_speed_rad_s / (2 * math.pi)
    coefficients = coefficients * transducer_response(orders * elec_hz, transducer_bandwidth_hz)
    theta = angle_grid()
    mean = float(coefficients[0].real)
    # θ_k = 2πk/N: Re Σ_{n≥1} c_n·e^{jnθ_k} is an inverse real DFT (same value, fast)
    line = np.zeros(theta.size // 2 + 1, dtype=complex)
    line[1:coefficients.size] = coefficients[1:] * (theta.size / 2)
    torque = np.fft.irfft(line, n=theta.size) + mean
    waveform = (torque - mean) / mean
    order6 = coefficients[6] / mean
    return Prediction(
        source="dead_time", pk_pk_pu=float(np.ptp(waveform)), base=MEAN_TORQUE_BASE + " with the "
        "dead-time fundamental included", base_nm=op.mean_torque_nm * mean, order=6.0,
        inputs=inputs, equations="average voltage error T_d·f_sw·V_dc per leg with the actual "
        "current's sign (eqs 32-37 averaged over a PWM period), periodic steady state",
        assumptions=[
            "leg error from the simulated (not the ideal) current at the leg's two edges: the "
            "PWM ripple's excursion (centre-aligned SVPWM) and zero-current clamping within the "
            "dead intervals included; diode drops and the loop's sampling neglected",
            loop_assumption(loop, bandwidth_hz, delay_s),
            f"orders 1..{CLAMPING_MAX_ORDER} kept" + (
                f"; first-order transducer {transducer_bandwidth_hz:g} Hz applied"
                if transducer_bandwidth_hz else "; air-gap torque (no transducer response)")],
        angle_rad=theta, waveform_pu=waveform,
        extras={"paper_pk_pk_pu": paper_pu, "current_step_a": step, "leg_error_v": eps,
                "order6_amplitude_pu": float(abs(order6)),
                "order6_phase_rad": float(np.angle(order6)),
                "phase_convention": "torque = c0 + Σ A_k·cos(kθ + φ_k), θ electrical angle "
                                    "(hil.analysis.metrics)"})
