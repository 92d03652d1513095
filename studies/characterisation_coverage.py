"""Study: identification coverage of the characterisation stage (issue 29 "Done when").

Run: ``.venv/bin/python studies/characterisation_coverage.py [--drives 40] [--seed 0]``
(writes ``studies/results/characterisation_coverage.md``; ``--no-write`` only prints).

Each drive draws its actual physics (``hil.characterisation.coverage.draw_drive``: R × 0.85…1.45,
L × 0.7…1.15 at the operating current, half of them saturating, Ke × 0.92…1.04, loop bandwidth
× 0.8…1.25, transducer bandwidth × 0.7…1.4) and an operating point (300–1000 rpm, 10–25 A); the
bench file keeps Table I. The stage runs through the simulated instruments as in ``hil run``; an
identified value is covered when |identified − truth| ≤ U (k = 2). Target: ≥ 95 % covered per
parameter, none beyond 3 U. ``current_loop_gain_pu``'s truth is the actual loop bandwidth over the
documented one (the gains' design bandwidth, the plant's own R, L measured apart).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from hil.characterisation.coverage import coverage, summary

RESULT = Path(__file__).parent / "results" / "characterisation_coverage.md"


def table(rows, stats, command: str, seconds: float) -> str:
    lines = ["# Identification coverage of the characterisation stage (issue 29)", "",
             f"Command: `{command}` ({seconds:.0f} s wall on the shared 2-core machine).", "",
             "| parameter | drives | within U (k = 2) | within 3U | worst \\|error\\|/U | "
             "median U/value |", "|---|---|---|---|---|---|"]
    for name, s in stats.items():
        lines.append(f"| `{name}` | {s['cases']} | {s['within_U']:.0%} | {s['within_3U']:.0%} "
                     f"| {s['worst_ratio']:.2f} | {s['median_rel_U']:.3%} |")
    lines += ["", "Per drive (truth → identified ± U):", "",
              "| drive | rpm | A | parameter | truth | identified | U | \\|error\\|/U |",
              "|---|---|---|---|---|---|---|---|"]
    for row in rows:
        if row["value"] is None:
            lines.append(f"| {row['drive']} | {row['speed_rpm']:.0f} | {row['current_a']:.1f} | "
                         f"`{row['name']}` | {row['truth']:.6g} | not identified: "
                         f"{row['not_identified']} | | |")
            continue
        lines.append(f"| {row['drive']} | {row['speed_rpm']:.0f} | {row['current_a']:.1f} | "
                     f"`{row['name']}` | {row['truth']:.6g} | {row['value']:.6g} | "
                     f"{row['U']:.3g} | {row['ratio']:.3f} |")
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--drives", type=int, default=40)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--no-write", action="store_true")
    args = parser.parse_args()
    start = time.perf_counter()
    rows = coverage(args.drives, seed=args.seed)
    stats = summary(rows)
    command = (f".venv/bin/python studies/characterisation_coverage.py --drives {args.drives} "
               f"--seed {args.seed}")
    text = table(rows, stats, command, time.perf_counter() - start)
    print(text.split("\n\nPer drive")[0])
    if not args.no_write:
        RESULT.write_text(text)


if __name__ == "__main__":
    main()
