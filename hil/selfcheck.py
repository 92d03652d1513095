"""Bench self-checks: does the bench measure what it claims? (design.md §7, verdict kind 3)

Run on one capture with nothing injected, at a point where the drive regulates its current well:

* **torque scale** — the measured mean torque against the nameplate K_t·I·cos φ (paper eq 7 with
  γ = 0): catches a transducer scale error and a drive whose torque constant is not the motor's;
* **current channels** — the fundamental of the DAQ's phase currents (least squares on the
  encoder's electrical angle) against the commanded peak current: catches a mis-scaled current
  channel or a drive that does not deliver what it is told;
* **speed** — the speed from the encoder counts against the dyno setpoint: catches a wrong time
  base (dropped or duplicated samples) or encoder scaling;
* **sampling** — the number of samples against the capture length × rate, uniform time base.

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
