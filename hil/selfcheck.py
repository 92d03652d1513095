"""Bench self-checks: does the bench measure what it claims? (design.md §7, verdict kind 3)

Run on one capture with nothing injected, at a point where the drive regulates its current well:

* **torque scale** — the measured mean torque against the nameplate K_t·I·cos φ (paper eq 7 with
  γ = 0): catches a transducer scale error and a drive whose torque constant is not the motor's;
* **current channels** — the fundamental of the DAQ's phase currents (least squares on the
  encoder's electrical angle) against the commanded peak current: catches a mis-scaled current
  channel or a drive that does not deliver what it is told;
* **speed** — the speed from the encoder counts against the dyno setpoint: catches a wrong time
  base (dropped or duplicated samples) or encoder scaling;
* **sampling** — the number of samples against the capture length × rate, uniform time base;
* **angle reference** — with no current (drive disabled or at 0 A) and the dyno turning the motor,
  the phase voltages are the back EMF: the electrical angle of phase a's back-EMF rising zero
  crossing against the DAQ's angle channel (:func:`emf_angle_reference`), recorded for the
  diagnosis (hil/diagnosis/README.md) and checked against the bench file's stated value;
* **transducer dynamics** — one injected ripple order measured at two speeds: the ratio of the
  two phasors against the bench file's first-order transducer bandwidth (amplitude and phase;
  :func:`transducer_response`): catches a transducer that lags more than the bench file states.

Each check is a dict ``{name, measured, expected, unit, tolerance, passed, detail}`` (the record
contract). A failed self-check voids every other verdict of the run.
"""

from __future__ import annotations

import math

import numpy as np

from hil.capture import Capture


def check(name: str, measured: float, expected: float, unit: str, tolerance: float,
          detail: str) -> dict:
    """One self-check: passes when |measured − expected| ≤ tolerance (all in ``unit``)."""
    ok = bool(math.isfinite(measured) and abs(measured - expected) <= tolerance)
    return {"name": name, "measured": float(measured), "expected": float(expected),
            "unit": unit, "tolerance": float(tolerance), "passed": ok, "detail": detail}


def torque_scale(capture: Capture, nameplate_nm: float, tolerance_pu: float, *,
                 basis: str | None = None) -> dict:
    """Mean of the transducer's torque over the capture vs the expected mean torque K_t·I·cos φ
    (N·m); ``basis`` says where K_t and the tolerance come from (default: the nameplate)."""
    measured = float(np.mean(capture["torque_nm"]))
    return check("torque scale", measured, nameplate_nm, "N*m", tolerance_pu * abs(nameplate_nm),
                 f"mean torque vs K_t·I·cos φ = {nameplate_nm:.4g} N·m "
                 f"(tolerance {tolerance_pu:.2%}: "
                 + (basis or "transducer class + nameplate K_t") + ")")


def electrical_angle(capture: Capture, pole_pairs: int) -> np.ndarray:
    """Electrical angle from the encoder channel (rad), relative to the first sample."""
    if "rotor_angle_mech_rad" in capture:
        mech = capture["rotor_angle_mech_rad"]
    else:
        cpr = float(capture.meta["encoder_counts_per_rev"])
        mech = np.asarray(capture["encoder_counts"], dtype=float) * (2.0 * math.pi / cpr)
    return pole_pairs * (np.asarray(mech, dtype=float) - float(mech[0]))


def fundamental_amplitude(signal: np.ndarray, theta_e: np.ndarray) -> float:
    """Peak amplitude of the component of ``signal`` at the electrical frequency (least squares
    on cos θ, sin θ and a constant; exact for whole revolutions, robust to partial ones)."""
    basis = np.column_stack([np.cos(theta_e), np.sin(theta_e), np.ones_like(theta_e)])
    coef, *_ = np.linalg.lstsq(basis, np.asarray(signal, dtype=float), rcond=None)
    return float(math.hypot(coef[0], coef[1]))


def current_channels(capture: Capture, commanded_a: float, pole_pairs: int,
                     tolerance_pu: float) -> list[dict]:
    """Each DAQ phase-current channel's fundamental vs the commanded peak current (A)."""
    theta = electrical_angle(capture, pole_pairs)
    checks = []
    for name in ("ia_a", "ib_a"):
        if name not in capture:
            continue
        amplitude = fundamental_amplitude(capture[name], theta)
        checks.append(check(f"current channel {name}", amplitude, commanded_a, "A",
                            tolerance_pu * commanded_a,
                            f"fundamental of the DAQ's {name} vs the commanded peak current"))
    return checks


def speed(capture: Capture, setpoint_rpm: float, tolerance_pu: float) -> dict:
    """Mean speed from the encoder angle over the capture's time base vs the dyno setpoint."""
    time_s = np.asarray(capture["time_s"], dtype=float)
    theta_m = electrical_angle(capture, 1)
    slope = float(np.polyfit(time_s, theta_m, 1)[0]) if len(time_s) > 1 else math.nan
    measured_rpm = slope * 60.0 / (2.0 * math.pi)
    return check("speed", measured_rpm, setpoint_rpm, "rpm", tolerance_pu * abs(setpoint_rpm),
                 "encoder angle slope over the DAQ time base vs the dyno setpoint")


def sampling(capture: Capture, duration_s: float, rate_hz: float) -> dict:
    """Samples received vs duration × rate; the time base must step by 1/rate (± 1e-6)."""
    expected = int(round(duration_s * rate_hz))
    time_s = np.asarray(capture["time_s"], dtype=float)
    steps = np.diff(time_s)
    uniform = bool(steps.size == 0 or np.all(np.abs(steps * rate_hz - 1.0) <= 1e-6))
    return check("sampling", len(time_s) if uniform else math.nan, expected, "samples", 0.0,
                 f"samples received vs {duration_s:.4g} s × {rate_hz:g} Hz; time base "
                 + ("uniform" if uniform else "NOT uniform"))


def order_phasor(result, order: int) -> tuple[complex, float]:
    """(A_k·e^{jφ_k} per unit of the mean torque, the expanded relative U of A_k, k = 2) of an
    analysed capture (``hil.analysis.RippleResult``)."""
    amplitude = float(result.amplitude_nm[order - 1])
    phasor = amplitude * complex(math.cos(result.phase_rad[order - 1]),
                                 math.sin(result.phase_rad[order - 1])) / result.mean_torque_nm
    u_rel = 2.0 * float(result.amplitude_u_nm[order - 1]) / amplitude if amplitude > 0 \
        else math.inf
    return phasor, u_rel


def signal_resolved(result, order: int, speed_rpm: float) -> dict:
    """The dynamics check's test signal (an injected order) is resolved: A_k > 10·U(A_k), so
    that its phase is known to better than ≈ 0.1 rad. Fails when the drive did not produce it
    (then the transducer's dynamics cannot be checked)."""
    _, u_rel = order_phasor(result, order)
    return check(f"transducer dynamics: order-{order} test signal at {speed_rpm:g} rpm",
                 u_rel, 0.0, "1 (U(A)/A)", 0.1,
                 f"expanded U of the order-{order} amplitude per unit of the amplitude "
                 f"(≤ 0.1: the injected test signal is resolved)")


def transducer_response(reference, response, order: int, *, reference_hz: float,
                        response_hz: float, direction: int, bandwidth_hz: float,
                        loop_bound_rad: float) -> list[dict]:
    """The transducer's amplitude and phase response against the bench file's first-order
    bandwidth (issue 21 item 7), from one torque-ripple order measured at two speeds.

    The injected ripple is a function of the electrical angle only (eq 25: the gain mismatch's
    order 2 under current regulation), so the same order at two speeds differs only by what
    depends on frequency: the transducer H(f) = 1/(1 + j·f/f_t) and the current loop. The ratio
    of the two phasors (per unit of each capture's mean torque) must therefore be
    |H(f₂)|/|H(f₁)| in amplitude and −direction·(atan(f₂/f_t) − atan(f₁/f_t)) in phase (a lag
    in time is a shift back along the angle the rotor travels). Tolerances: the measured U of
    both phasors (k = 2, root-sum-square) plus the current loop's lag bound at f₂
    (``loop_bound_rad``, atan(f/f_c) + 2π·f·τ_d of the stated loop: the loop's lags at both
    speeds have one sign, so their difference is within the larger), which also bounds its
    relative amplitude effect. A transducer lagging 1 ms more than stated moves the phase by
    ≈ 2π·(f₂ − f₁)·1 ms.
    """
    c1, u1 = order_phasor(reference, order)
    c2, u2 = order_phasor(response, order)
    ratio = c2 / c1
    u_rel = math.hypot(u1, u2)
    h1 = 1.0 / complex(1.0, reference_hz / bandwidth_hz)
    h2 = 1.0 / complex(1.0, response_hz / bandwidth_hz)
    expected_phase = -direction * (math.atan(response_hz / bandwidth_hz)
                                   - math.atan(reference_hz / bandwidth_hz))
    measured_phase = math.remainder(math.atan2(ratio.imag, ratio.real), 2.0 * math.pi)
    stated = f"the bench file's first-order {bandwidth_hz:g} Hz"
    return [
        check("transducer dynamics: amplitude", abs(ratio), abs(h2) / abs(h1), "1",
              u_rel + loop_bound_rad,
              f"order-{order} amplitude at {response_hz:.4g} Hz / at {reference_hz:.4g} Hz vs "
              f"{stated}"),
        check("transducer dynamics: phase", measured_phase, expected_phase, "rad",
              u_rel + loop_bound_rad,
              f"order-{order} phase at {response_hz:.4g} Hz − at {reference_hz:.4g} Hz vs "
              f"{stated} (a 1 ms longer lag moves it by "
              f"{2 * math.pi * (response_hz - reference_hz) * 1e-3:.3f} rad)"),
    ]


#: Line-to-line v_ab leads phase a's line-to-neutral voltage by 30° electrical.
LINE_TO_LINE_LEAD_DEG = 30.0
#: Largest standard uncertainty (degrees electrical) of a measured angle reference that passes.
MAX_REFERENCE_U_DEG = 5.0


def emf_angle_reference(capture: Capture, pole_pairs: int, *, speed_rpm: float,
                        stated_elec_deg: float | None = None,
                        encoder_counts_per_rev: int | None = None,
                        channel_skew_bound_s: float | None = None) -> dict:
    """The capture's angle reference from its voltage channels while no current flows: the
    back EMF of phase a is e_a = s·E·sin(θ_c − ref) (s the sign of the speed; paper eq 7's e_a =
    E·sin θ_e with the capture's electrical angle θ_c = θ_e + ref). Phase a's line-to-neutral
    ``va_v``, else line-to-line ``vab_v`` (which leads it by 30°), is fitted per electrical
    revolution on {cos θ_c, sin θ_c, 1}; ref = atan2(−s·A, s·B).

    Standard uncertainty (degrees electrical): the scatter of the per-revolution values (type A),
    the angle channel's quantisation (a count of ``encoder_counts_per_rev``, ×p electrical, /√12)
    and the time skew between the voltage and the angle channels, bounded by
    ``channel_skew_bound_s`` (default: one sample period — a multiplexed DAQ samples its channels
    within one; a voltage averaged over a PWM period lags by up to half of one), rectangular:
    360°·f_e·bound/√3 — measure at a low speed to make it small. It assumes no current flows
    (with current, R·i + L·di/dt shifts the terminal voltage's phase).

    A check dict (the record contract) with ``measured`` the reference in degrees and
    ``u_elec_deg``; when ``stated_elec_deg`` (the bench file's value) is given it passes only when
    the two agree within U = 2·u; either way only when the measurement is resolved
    (u < :data:`MAX_REFERENCE_U_DEG`).
    """
    from hil.diagnosis.angle_reference import wrap_deg

    if "va_v" in capture:
        volts, lead_deg, channel = np.asarray(capture["va_v"], dtype=float), 0.0, "va_v"
    elif "vab_v" in capture:
        volts, lead_deg, channel = (np.asarray(capture["vab_v"], dtype=float),
                                    LINE_TO_LINE_LEAD_DEG, "vab_v")
    else:
        return check("angle reference (back EMF)", math.nan, stated_elec_deg or 0.0, "deg", 0.0,
                     "the capture has no voltage channel (va_v or vab_v): the back EMF's angle "
                     "cannot be measured")
    theta = np.unwrap(np.asarray(capture["rotor_angle_mech_rad"], dtype=float)) * pole_pairs
    direction = 1.0 if speed_rpm >= 0 else -1.0
    turns = np.floor((theta - theta[0]) * direction / (2 * math.pi))
    values = []
    for turn in np.unique(turns)[:-1]:
        pick = turns == turn
        if pick.sum() < 16:
            continue
        basis = np.column_stack([np.cos(theta[pick]), np.sin(theta[pick]), np.ones(pick.sum())])
        (a, b, _), *_ = np.linalg.lstsq(basis, volts[pick], rcond=None)
        values.append(math.atan2(-direction * a, direction * b))
    if len(values) < 2:
        return check("angle reference (back EMF)", math.nan, stated_elec_deg or 0.0, "deg", 0.0,
                     "fewer than two electrical revolutions in the capture")
    phasors = np.exp(1j * np.array(values))
    mean = float(np.angle(phasors.mean()))
    spread = np.angle(phasors * np.exp(-1j * mean))
    u_a = math.degrees(float(np.std(spread, ddof=1)) / math.sqrt(spread.size))
    u_q = (360.0 * pole_pairs / encoder_counts_per_rev / math.sqrt(12.0)
           if encoder_counts_per_rev else 0.0)
    time_s = np.asarray(capture["time_s"], dtype=float)
    skew_s = (channel_skew_bound_s if channel_skew_bound_s is not None
              else float(np.median(np.diff(time_s))))
    elec_hz = abs(speed_rpm) / 60.0 * pole_pairs
    u_skew = 360.0 * elec_hz * skew_s / math.sqrt(3.0)
    u_deg = math.sqrt(u_a ** 2 + u_q ** 2 + u_skew ** 2)
    measured = wrap_deg(math.degrees(mean) + lead_deg)
    expected = measured if stated_elec_deg is None else float(stated_elec_deg)
    diff = wrap_deg(measured - expected)
    tolerance = 2.0 * u_deg if stated_elec_deg is not None else 0.0
    out = check("angle reference (back EMF)", expected + diff, expected, "deg", tolerance,
                f"phase a's back-EMF rising zero crossing at {measured:.4g}° ± {2 * u_deg:.2g}° "
                f"(k = 2) of the angle channel's electrical angle, from {channel} over "
                f"{len(values)} electrical revolutions" + (
                    f"; the bench file states {stated_elec_deg:g}°" if stated_elec_deg is not None
                    else "; the bench file states none"))
    # resolved at all: a reference known to worse than 5° (u) cannot check or sign anything
    out["passed"] = bool(u_deg < MAX_REFERENCE_U_DEG and (stated_elec_deg is None
                                                         or out["passed"]))
    out["u_elec_deg"] = u_deg
    out["emf_a_rising_zero_elec_deg"] = measured
    return out
