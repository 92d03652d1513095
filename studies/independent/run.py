"""Driver, in the project's own venv, of the independent simulator (motulator 0.18 in
``.venv-motulator``; ``studies/independent/motulator_captures.py`` runs there).

``generate(spec, out_dir)`` runs the generator in a subprocess and returns the manifest's path;
``random_drive(rng)`` draws one drive of the coverage study (issue 23 item 6): random sensor
offsets (±0.3 A), gains (±2 %), dead time (0–2 µs, a quarter of the drives none), a loop
(bandwidth 500–3000 Hz, motulator's continuous 2-DOF or direct discrete design) and one of two
motors (Table I; an 8-pole 48 V motor).
"""

from __future__ import annotations

import json
import math
import os
import subprocess
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
VENV_PYTHON = REPO / ".venv-motulator" / "bin" / "python"
GENERATOR = Path(__file__).resolve().parent / "motulator_captures.py"
LOOP_RESPONSE = Path(__file__).resolve().parent / "motulator_loop_response.py"

#: Motors of the study, in the generator's spec keys (SI: Ω, H, V·s per electrical rad, V).
MOTORS = {
    # paper Table I: 4 poles, 12 V, 55 mΩ, 38.5 µH, Ke 0.023 V/(rad/s) rms phase
    "table_i": {"name": "table_i", "pole_pairs": 2, "R_s_ohm": 55e-3, "L_d_h": 38.5e-6,
                "L_q_h": 38.5e-6, "psi_f_vs": math.sqrt(2.0) * 0.023 / 2, "u_dc_v": 12.0},
    # the validity study's 8-pole 48 V motor: 0.12 Ω, 0.3 mH, Ke 0.06 V/(rad/s) rms phase
    "p8_48v": {"name": "p8_48v", "pole_pairs": 4, "R_s_ohm": 0.12, "L_d_h": 0.3e-3,
               "L_q_h": 0.3e-3, "psi_f_vs": math.sqrt(2.0) * 0.06 / 4, "u_dc_v": 48.0},
}
#: Operating points per motor (speed rpm, peak current A): two speeds at one current and one at
#: another current (what the diagnosis asks for), one of them in reverse rotation.
POINTS = {
    "table_i": [(500.0, 20.0), (1000.0, 20.0), (1000.0, 10.0)],
    "p8_48v": [(400.0, 15.0), (800.0, 15.0), (800.0, 8.0)],
}


class SimulatorMissing(RuntimeError):
    """``.venv-motulator`` is not there (``.ci/setup-motulator`` creates it)."""


def available() -> bool:
    return VENV_PYTHON.is_file() and VENV_PYTHON.parent.parent.joinpath(
        ".motulator-stamp").is_file()


def generate(spec: dict, out_dir: str | Path, *, timeout_s: float = 1800.0,
             jobs: int = 1) -> Path:
    """Simulate ``spec`` with motulator into ``out_dir`` (its points in ``jobs`` processes at
    once); returns ``out_dir/manifest.toml``."""
    if not available():
        raise SimulatorMissing(f"{VENV_PYTHON.parent.parent} is missing or unfinished: run "
                               ".ci/setup-motulator (it needs a Python 3.12 or 3.13 for "
                               "motulator 0.18)")
    out_dir = Path(out_dir)
    proc = subprocess.run([str(VENV_PYTHON), str(GENERATOR), "--jobs", str(jobs), "-",
                           str(out_dir)],
                          input=json.dumps(spec), text=True, capture_output=True,
                          timeout=timeout_s, env={k: v for k, v in os.environ.items()
                                                  if k != "PYTHONPATH"})
    if proc.returncode != 0:
        raise RuntimeError(f"motulator generator failed (exit {proc.returncode}):\n"
                           f"{proc.stderr[-3000:]}")
    manifest = out_dir / "manifest.toml"
    if not manifest.is_file():
        raise RuntimeError(f"motulator generator wrote no {manifest}")
    return manifest


def loop_response(spec: dict, *, timeout_s: float = 600.0) -> dict[float, complex]:
    """motulator's current loop alone under a rotor-frame voltage disturbance
    (``motulator_loop_response.py``, its docstring for ``spec``): {ω_d rad/s: current per volt
    A/V}."""
    if not available():
        raise SimulatorMissing(f"{VENV_PYTHON.parent.parent} is missing or unfinished: run "
                               ".ci/setup-motulator")
    proc = subprocess.run([str(VENV_PYTHON), str(LOOP_RESPONSE)], input=json.dumps(spec),
                          text=True, capture_output=True, timeout=timeout_s,
                          env={k: v for k, v in os.environ.items() if k != "PYTHONPATH"})
    if proc.returncode != 0:
        raise RuntimeError(f"motulator loop response failed (exit {proc.returncode}):\n"
                           f"{proc.stderr[-3000:]}")
    return {row["frequency_rad_s"]: complex(*row["response_a_per_v"])
            for row in json.loads(proc.stdout)["responses"]}


def restate(out_dir: str | Path) -> Path:
    """Rewrite a capture folder's manifest with the generator's current statement (no
    simulation)."""
    if not available():
        raise SimulatorMissing(f"{VENV_PYTHON} does not exist: run .ci/setup-motulator")
    proc = subprocess.run([str(VENV_PYTHON), str(GENERATOR), "--restate", str(out_dir)],
                          text=True, capture_output=True, timeout=120)
    if proc.returncode != 0:
        raise RuntimeError(f"restating {out_dir} failed: {proc.stderr[-2000:]}")
    return Path(out_dir) / "manifest.toml"


def random_drive(rng, *, mech_revolutions: int = 3, pwm_model: str = "carrier",
                 motor: str | None = None) -> dict:
    """One random drive's spec (``rng``: numpy Generator)."""
    name = motor or str(rng.choice(sorted(MOTORS)))
    reverse = bool(rng.random() < 0.3)
    points = []
    for k, (speed, current) in enumerate(POINTS[name]):
        sign = -1.0 if reverse else 1.0
        points.append({"speed_rpm": sign * speed, "current_a": current,
                       "current_angle_deg": 0.0, "mech_revolutions": mech_revolutions})
    dead_time = 0.0 if rng.random() < 0.25 else float(rng.uniform(0.0, 2e-6))
    return {
        "motor": MOTORS[name],
        "loop": {"bandwidth_hz": float(rng.uniform(500.0, 3000.0)),
                 "design": str(rng.choice(["continuous", "discrete"])),
                 "pwm_frequency_hz": 20_000.0, "pwm_model": pwm_model},
        "faults": {"ia_offset_a": float(rng.uniform(-0.3, 0.3)),
                   "ib_offset_a": float(rng.uniform(-0.3, 0.3)),
                   "ia_gain_error_pu": float(rng.uniform(-0.02, 0.02)),
                   "ib_gain_error_pu": float(rng.uniform(-0.02, 0.02)),
                   "dead_time_s": dead_time},
        "points": points,
        "settle_s": 0.02,
    }


def issue23_drive(*, dead_time_s: float, points: list[tuple[float, float]],
                  mech_revolutions: int = 3, pwm_model: str = "carrier") -> dict:
    """Issue 23's fixed drive: Table I, Δa +0.30 A, Δb −0.10 A, g_a +1.5 %, motulator's
    continuous 2-DOF loop at 1 kHz, 20 kHz SVPWM; ``points`` as (speed rpm, current A)."""
    return {"motor": MOTORS["table_i"],
            "loop": {"bandwidth_hz": 1000.0, "design": "continuous",
                     "pwm_frequency_hz": 20_000.0, "pwm_model": pwm_model},
            "faults": {"ia_offset_a": 0.30, "ib_offset_a": -0.10, "ia_gain_error_pu": 0.015,
                       "ib_gain_error_pu": 0.0, "dead_time_s": dead_time_s},
            "points": [{"speed_rpm": s, "current_a": c, "current_angle_deg": 0.0,
                        "mech_revolutions": mech_revolutions} for s, c in points],
            "settle_s": 0.02}
