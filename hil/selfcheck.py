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


def torque_scale(capture: Capture, nameplate_nm: float, tolerance_pu: float) -> dict:
    """Mean of the transducer's torque over the capture vs the nameplate mean torque (N·m)."""
    measured = float(np.mean(capture["torque_nm"]))
    return check("torque scale", measured, nameplate_nm, "N*m", tolerance_pu * abs(nameplate_nm),
                 f"mean torque vs K_t·I·cos φ = {nameplate_nm:.4g} N·m "
                 f"(tolerance {tolerance_pu:.1%}: transducer class + nameplate K_t)")


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
