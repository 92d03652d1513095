"""Study: the loop model's type-B uncertainty (``hil.characterisation.loop.MODEL_U_PU``), measured
on a calibration set of drives and checked on a held-out one (issue 29).

Run: ``.venv/bin/python studies/loop_model_calibration.py [--drives 30] [--seed 0 1]``
(writes ``studies/results/loop_model_calibration.md``; ``--no-write`` only prints).

The drives are the coverage study's (``hil.characterisation.coverage.draw_drive``, same seeds),
characterised as ``hil run`` does; the stage's loop points (order, H_k, type-A u) are kept. Per
point, the model (``model_response`` × the truncation factor of a speed that is not synchronous
with the PWM, sinc²(k·Δ/2)) at the drive's *true* g, R and L, with the frame offset δ fitted, is
compared with H_k: the relative residual per component |H_k − model|/(√2·|H_k|). Seed 0
calibrates (``MODEL_U_PU`` is its RMS at the top test order, rounded up), seed 1 checks it.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from unittest import mock

import numpy as np
from scipy.optimize import least_squares

from hil.characterisation import loop
from hil.characterisation.coverage import characterise_drive, draw_drive

RESULT = Path(__file__).parent / "results" / "loop_model_calibration.md"
#: The stage's fit, called through after its arguments are kept.
FIT_LOOP = loop.fit_loop


def loop_points(count: int, seed: int) -> list[dict]:
    """Per drive: its truth and the (points, setup) the stage fitted."""
    rng = np.random.default_rng(seed)
    out = []
    for index in range(count):
        drive = draw_drive(rng)
        seen = {}

        def keep(points, setup, plant, u_inductance, seen=seen):
            seen.update(points=points, setup=setup)
            return FIT_LOOP(points, setup, plant, u_inductance)
        with mock.patch.object(loop, "fit_loop", keep):
            characterise_drive(drive, seed=seed + index)
        out.append({"truth": drive["truth"], **seen})
    return out


def residuals(drive: dict) -> np.ndarray:
    """Per point, |H_k − model|/(√2·|H_k|) at the true g, R, L (δ fitted; uniform truncation)."""
    truth, setup = drive["truth"], drive["setup"]
    orders = np.array([order for order, _, _ in drive["points"]], dtype=float)
    measured = np.array([h for _, h, _ in drive["points"]])
    u_a = np.array([u for _, _, u in drive["points"]])
    plant = (truth["phase_resistance_ohm"], truth["phase_inductance_h"])
    model = loop.model_response(orders * setup.omega_e_rad_s, truth["current_loop_gain_pu"],
                                plant, setup) \
        * np.sinc(orders * setup.count_elec_rad / (2 * math.pi)) ** 2

    def error(x):
        e = (model * np.exp(1j * orders * x[0]) - measured) / u_a
        return np.concatenate([e.real, e.imag])
    frame = least_squares(error, [0.0]).x[0]
    return np.abs(model * np.exp(1j * orders * frame) - measured) / (math.sqrt(2) * abs(measured))


def section(seed: int, drives: list[dict]) -> str:
    per_point = np.array([residuals(drive) for drive in drives])      # drives × 3 orders
    rms = np.sqrt(np.mean(per_point ** 2, axis=0))
    lines = [f"## seed {seed} ({len(drives)} drives)", "",
             "| test order (share of the documented bandwidth) | RMS per component | max |",
             "|---|---|---|"]
    for share, value, worst in zip(("¼", "½", "1"), rms, per_point.max(axis=0)):
        lines.append(f"| {share} | {value:.3%} | {worst:.3%} |")
    lines += ["", f"All orders: RMS {np.sqrt(np.mean(per_point ** 2)):.3%}, max "
              f"{per_point.max():.3%}; `MODEL_U_PU` = {loop.MODEL_U_PU:.2%}.", ""]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--drives", type=int, default=30)
    parser.add_argument("--seed", type=int, nargs="+", default=[0, 1])
    parser.add_argument("--no-write", action="store_true")
    args = parser.parse_args()
    seeds = " ".join(str(seed) for seed in args.seed)
    text = ["# The loop model's type-B uncertainty: calibration and held-out check", "",
            f"Command: `.venv/bin/python studies/loop_model_calibration.py --drives "
            f"{args.drives} --seed {seeds}` (method: the study's docstring).", ""]
    for seed in args.seed:
        text.append(section(seed, loop_points(args.drives, seed)))
        print(text[-1], flush=True)
    if not args.no_write:
        RESULT.write_text("\n".join(text))


if __name__ == "__main__":
    main()
