"""Study: coverage of the standard-additions path on random simulated drives (issue 23 item 1).

Run: ``.venv/bin/python studies/additions_coverage.py [--drives 40] [--seed 0]``.

Each drive gets random faults of its own (sensor offsets ±0.3 A, gain errors ±2 %, dead time
0-2 µs, one cogging term of 0-20 mN·m at mechanical order 4 or 12 — the gain's and the dead
time's orders with p = 2) set on the twin; the diagnosis plan's addition design
(``testplans/diagnosis_design.py``: the known additions on top of the drive's own faults, and the
base points of the same speed and current) is simulated and handed to
:func:`hil.diagnosis.additions.diagnose_by_additions`. Each stated estimate is checked against
the hidden value in the additions' units (o_a, o_b, θ_g = (1 + g_a)/(1 + g_b) − 1, T_d):
covered when |estimate − hidden| ≤ U (k = 2). Printed: coverage, mean |error|/U, how often a
parameter was not stated and why (e.g. "not linear over the addition"), and the worst
confident miss (|error| > 3U).
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from hil.diagnosis.additions import DEFAULT_TOLERANCE_PU, diagnose_by_additions
from hil.diagnosis.additions_proof import simulate_additions
from hil.diagnosis.twin_proof import twin_setup
from hil.sim import DriveConfig, Injection, MotorModel
from ripple_hil_testplans import diagnosis_design as design

NAMES = ("ia_offset_a", "ib_offset_a", "gain_a_rel_b_pu", "dead_time_us")


def draw(rng: np.random.Generator, max_dead_time_s: float = 2e-6) -> tuple[dict, tuple]:
    faults = {"ia_offset_a": float(rng.uniform(-0.3, 0.3)),
              "ib_offset_a": float(rng.uniform(-0.3, 0.3)),
              "ia_gain_error_pu": float(rng.uniform(-0.02, 0.02)),
              "ib_gain_error_pu": float(rng.uniform(-0.02, 0.02)),
              "dead_time_s": float(rng.uniform(0.0, 1.0)) * max_dead_time_s}
    cogging = ((int(rng.choice((4, 12))), float(rng.uniform(0.0, 0.02)),
                float(rng.uniform(-math.pi, math.pi))),)
    return faults, cogging


def hidden_values(faults: dict) -> dict:
    return {"ia_offset_a": faults["ia_offset_a"], "ib_offset_a": faults["ib_offset_a"],
            "gain_a_rel_b_pu": (1 + faults["ia_gain_error_pu"])
            / (1 + faults["ib_gain_error_pu"]) - 1,
            "dead_time_us": faults["dead_time_s"] * 1e6}


def runs() -> list:
    """The plan's addition points and the base point of each (speed, current) they use."""
    bases = sorted({(speed, current) for speed, current, _, _ in design.ADDITIONS})
    return [(s, i, None, 0.0) for s, i in bases] + list(design.ADDITIONS)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--drives", type=int, default=40)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--max-dead-time-us", type=float, default=2.0,
                        help="hidden dead time drawn from 0..this (0: none, to isolate the "
                             "dead time's interaction with the offsets)")
    parser.add_argument("--tolerance-pu", type=float, default=DEFAULT_TOLERANCE_PU,
                        help="each addition's relative standard uncertainty (the twin's are "
                             "exact: 0 shows the spectra's own share)")
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    rows = {name: [] for name in NAMES}
    reasons: dict[str, dict[str, int]] = {name: {} for name in NAMES}
    worst = []
    started = time.time()
    for drive in range(args.drives):
        faults, cogging = draw(rng, args.max_dead_time_us * 1e-6)
        config = DriveConfig(injection=Injection(**faults), motor=MotorModel(cogging=cogging))
        pairs = simulate_additions(config, runs(), revolutions_elec=design.REVOLUTIONS_ELEC,
                                   sample_rate_hz=design.SAMPLE_RATE_HZ,
                                   settle_s=design.SETTLE_S, seed=args.seed * 10_000 + drive)
        result = diagnose_by_additions(pairs, setup=twin_setup(config), max_mech_order=32,
                                       tolerance_pu=args.tolerance_pu)
        for name, hidden in hidden_values(faults).items():
            entry = result.estimate(name)
            if entry is None or not entry["stated"]:
                reason = (entry or {}).get("reason") or "absent"
                short = reason.split(":")[0]
                reasons[name][short] = reasons[name].get(short, 0) + 1
                continue
            error = entry["estimate"] - hidden
            big_u = entry["expanded_uncertainty"]
            rows[name].append((abs(error) <= big_u, abs(error) / big_u))
            if abs(error) > 1.5 * big_u:
                worst.append((abs(error) / big_u, drive, name, hidden, entry["estimate"], big_u))
    print(f"{args.drives} drives, seed {args.seed}, addition tolerance {args.tolerance_pu:g}, "
          f"{time.time() - started:.0f} s")
    print(f"{'parameter':<18}{'stated':>8}{'covered':>10}{'mean |err|/U':>14}  not stated")
    for name in NAMES:
        stated = rows[name]
        covered = sum(c for c, _ in stated)
        mean = np.mean([r for _, r in stated]) if stated else float("nan")
        pct = 100.0 * covered / len(stated) if stated else float("nan")
        print(f"{name:<18}{len(stated):>8}{pct:>9.0f}%{mean:>14.2f}  "
              f"{'; '.join(f'{k} ({v})' for k, v in reasons[name].items()) or '-'}")
    confident = [w for w in worst if w[0] > 3.0]
    print(f"misses beyond 1.5 U: {len(worst)}; beyond 3 U (confident wrong): {len(confident)}")
    for ratio, drive, name, hidden, estimate, big_u in sorted(worst, reverse=True)[:5]:
        print(f"  drive {drive}: {name} hidden {hidden:+.5g}, estimate {estimate:+.5g} ± "
              f"{big_u:.2g} (|err|/U {ratio:.2f})")


if __name__ == "__main__":
    main()
