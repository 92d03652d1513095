"""Proof of the standard-additions path on the digital twin: the drive's own (hidden) faults set
on the twin, the known additions made on top of them, the captures simulated and handed to
:func:`hil.diagnosis.additions.diagnose_by_additions` (issue 23 item 1).

Only the proof runs ``hil.sim``; the additions path itself uses no model of the drive.
"""

from __future__ import annotations

from dataclasses import replace

from hil.capture import Capture
from hil.sim import DriveConfig, Injection, simulate_batch


def injection_with_addition(base: Injection, key: str | None, value: float) -> Injection:
    """The drive's own injection state with one known addition on top: an offset adds to the
    sensor's reading (A), a gain step multiplies sensor a's gain by (1 + value), a dead-time
    step adds to the inverter's dead time (s); ``key`` None is the base capture."""
    knobs = base.as_dict()
    if key == "addition_ia_offset_a":
        knobs["ia_offset_a"] += value
    elif key == "addition_ib_offset_a":
        knobs["ib_offset_a"] += value
    elif key == "addition_gain_a_pu":
        knobs["ia_gain_error_pu"] = (1.0 + knobs["ia_gain_error_pu"]) * (1.0 + value) - 1.0
    elif key == "addition_dead_time_s":
        knobs["dead_time_s"] += value
    elif key is not None:
        raise ValueError(f"unknown addition {key!r}")
    return Injection(**knobs)


def simulate_additions(config: DriveConfig, runs, *, revolutions_elec: float,
                       sample_rate_hz: float, settle_s: float = 0.05,
                       seed: int = 0) -> list[tuple[Capture, dict]]:
    """(capture, operating point dict) of ``config`` for each run (speed rpm, current A,
    addition key or None, value), one batch per |speed| (equal capture lengths)."""
    pole_pairs = config.motor.parameters.pole_pairs
    out: list = [None] * len(runs)
    by_speed: dict[float, list[int]] = {}
    for index, run in enumerate(runs):
        by_speed.setdefault(abs(run[0]), []).append(index)
    for batch, (speed, indices) in enumerate(sorted(by_speed.items())):
        duration_s = (revolutions_elec + 0.25) / (speed / 60.0 * pole_pairs)
        configs = [replace(config, speed_rpm=runs[i][0], current_command_a=runs[i][1],
                           injection=injection_with_addition(config.injection, runs[i][2],
                                                             runs[i][3]))
                   for i in indices]
        results = simulate_batch(configs, duration_s, sample_rate_hz, settle_s=settle_s,
                                 seed=seed * 1000 + batch)
        for i, result in zip(indices, results):
            speed_rpm, current_a, key, value = runs[i]
            op = {"current_a": current_a,
                  "label": f"{speed_rpm:+g} rpm, {current_a:g} A" + (
                      f", {key} = {value:g}" if key else "")}
            if key:
                op[key] = value
            out[i] = (result.to_capture(), op)
    return out
