"""Study: agreement of the two yield engines (closed form vs switching-level twin) per drive.

Run: ``.venv/bin/python studies/yield_engines.py [--drives 48] [--scheduler inline|tcp://…]
[--workers 2] [--out out/yield_engines]``.

A shared set of drives is drawn from the shipped example tolerances
(``hil/examples/tolerances.toml``: sensor offsets and gains, dead time, encoder supplier, 16-bit
firmware) and each drive is evaluated by both engines at five operating points (low and high
speed, low and high current, a current angle of 30°). The twin runs on the campaign engine
(LocalCluster by default). Printed:

1. per operating point: median and range of twin/closed-form, the largest difference in % points,
   the correlation, and the share of drives whose pass/fail verdict at the 3 % limit differs —
   with the closed form's word-length and PWM-resolution bounds added (as ``hil yield`` does by
   default) and left out;
2. why: the same points with one source at a time (nothing, 1 % offset in both sensors, a ±1 %
   gain mismatch, 1.5 µs dead time, 16-bit firmware), twin against closed form;
3. the scatter plot (PNG and SVG) of every drive and point.

The closed form never sees the twin's numbers and vice versa.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import math
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from hil.campaign import chunk_seed, dask_client, run_campaign  # noqa: E402
from hil.model.core import OperatingPoint  # noqa: E402
from hil.tolerance.combiner import CombinerSettings, linear_range_warning  # noqa: E402
from hil.tolerance.engines import (ChunkJob, closed_form_ripple, sample_parameters,  # noqa: E402
                                   yield_chunk)
from hil.tolerance.spec import PARAMETERS, load_tolerances  # noqa: E402

#: 2500 rpm at 10 A is beyond SVPWM's voltage (hil.model refuses it unless asked): kept to show
#: what the twin does where no closed form applies.
POINTS = (OperatingPoint(500, 20), OperatingPoint(1500, 10),
          OperatingPoint(2500, 10, allow_beyond_voltage_limit=True),
          OperatingPoint(500, 5), OperatingPoint(1000, 20, math.radians(30)))
SOURCES = {"nothing": {}, "offset 1 % both": {"ia_offset_a": "1%", "ib_offset_a": "1%"},
           "gain ±1 %": {"ia_gain_error_pu": 0.01, "ib_gain_error_pu": -0.01},
           "dead time 1.5 µs": {"dead_time_s": 1.5e-6}, "16-bit firmware": {"word_length_bits": 16}}
LIMIT_PCT = 3.0


def label(op: OperatingPoint) -> str:
    return (f"{op.speed_rpm:g} rpm {op.current_a:g} A"
            + (f" φ {math.degrees(op.current_angle_rad):g}°" if op.current_angle_rad else ""))


def twin(spec, rows: dict, folder: Path, args, chunk: int = 8) -> np.ndarray:
    n = len(rows["dead_time_s"])
    jobs = [ChunkJob(spec=spec, engine="twin", rows={k: v[i:i + chunk] for k, v in rows.items()})
            for i in range(0, n, chunk)]
    result = run_campaign(yield_chunk, jobs, folder, scheduler=args.scheduler,
                          client=args.client, progress=False,
                          identity={"points": [label(p) for p in spec.operating_points],
                                    "rows": {k: np.asarray(v).tolist() for k, v in rows.items()}})
    return result.concatenated("ripple_pu")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--drives", type=int, default=48)
    parser.add_argument("--scheduler", default=None)
    parser.add_argument("--workers", type=int, default=None)
    parser.add_argument("--out", type=Path, default=ROOT / "out" / "yield_engines")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    with contextlib.ExitStack() as stack:
        args.client = None if args.scheduler == "inline" else stack.enter_context(
            dask_client(args.scheduler, args.workers))
        study(args)


def study(args: argparse.Namespace) -> None:
    spec = dataclasses.replace(load_tolerances(ROOT / "hil" / "examples" / "tolerances.toml"),
                               operating_points=POINTS)
    rows = sample_parameters(spec, np.random.default_rng(chunk_seed(spec.seed, 0)), args.drives)
    work = Path(tempfile.mkdtemp(prefix="yield_engines-"))
    twin_pct = 100 * twin(spec, rows, work / "drives", args)
    closed_pct = 100 * closed_form_ripple(POINTS, rows, args.drives)
    closed_nb_pct = 100 * closed_form_ripple(POINTS, rows, args.drives,
                                             CombinerSettings(bounds=False))

    print(f"{args.drives} drives from the example tolerances, both engines; ripple = pk-pk of "
          "the air-gap torque, orders 1..64, % of mean")
    print(f"{'operating point':<24}{'closed':>8}{'twin':>8}{'twin/closed':>22}{'max |Δ|':>9}"
          f"{'corr':>7}{'verdicts differ':>16}   closed form without bounds: twin/closed, differ")
    for j, op in enumerate(POINTS):
        ratio, ratio_nb = twin_pct[:, j] / closed_pct[:, j], twin_pct[:, j] / closed_nb_pct[:, j]
        differ = np.mean((twin_pct[:, j] > LIMIT_PCT) != (closed_pct[:, j] > LIMIT_PCT))
        differ_nb = np.mean((twin_pct[:, j] > LIMIT_PCT) != (closed_nb_pct[:, j] > LIMIT_PCT))
        print(f"{label(op):<24}{np.median(closed_pct[:, j]):7.2f}%{np.median(twin_pct[:, j]):7.2f}%"
              f"  {np.median(ratio):5.2f} ({ratio.min():.2f}..{ratio.max():.2f})"
              f"{np.max(np.abs(twin_pct[:, j] - closed_pct[:, j])):8.2f}pp"
              f"{np.corrcoef(twin_pct[:, j], closed_pct[:, j])[0, 1]:7.3f}"
              f"{100 * differ:15.1f}%   {np.median(ratio_nb):5.2f} "
              f"({ratio_nb.min():.2f}..{ratio_nb.max():.2f}), {100 * differ_nb:.1f}%")

    for op in POINTS:
        if linear_range_warning(op):
            print(f"  WARNING {linear_range_warning(op)}")
    print("\nwhy: one source at a time, % pk-pk (closed form without bounds | with | twin)")
    print(f"{'source':<18}" + "".join(f"{label(op):>27}" for op in POINTS))
    nominal = {name: np.array([spec.parameters[name].ppf(np.array([0.5]))[0] * 0
                               + PARAMETERS[name].nominal]) for name in PARAMETERS}
    for source, knobs in SOURCES.items():
        cells = []
        for op in POINTS:
            row = {k: v.copy() for k, v in nominal.items()}
            for name, value in knobs.items():
                row[name] = np.array([op.current_a / 100 if value == "1%" else value], float)
            one = dataclasses.replace(spec, operating_points=(op,))
            c_nb = 100 * closed_form_ripple((op,), row, 1, CombinerSettings(bounds=False))[0, 0]
            c_b = 100 * closed_form_ripple((op,), row, 1)[0, 0]
            t = 100 * twin(one, row, work / f"{source}-{label(op)}", args)[0, 0]
            cells.append(f"{c_nb:7.3f} |{c_b:7.3f} |{t:7.3f}")
        print(f"{source:<18}" + "".join(f"{cell:>27}" for cell in cells))
    paths = scatter(closed_pct, twin_pct, args.out)
    print(f"\nscatter plot: {paths[0]}, {paths[1]}")
    print(NOTES)


NOTES = """
why they differ (mechanisms; the figures are the ones printed above):
- "nothing": the twin has a floor the closed form has not — 12-bit ADC steps of 0.05 A and the
  PWM counter — that grows as the current falls (per unit of I); the closed form's PWM bound
  (bounds added) is of the same size at high current and larger at low current.
- word length: the paper's eq 14 bound is added whole to every drive; the twin's 16-bit firmware
  barely moves the ripple from its floor, so with bounds the closed form is conservative.
- dead time: the closed form is the average-voltage model with a continuous-time PI loop and
  current directions from ideal sinusoids; the twin samples the loop once per PWM period and
  clamps the current at its zero crossings — the twin is higher at low current and lower at a
  30° current angle.
- above the SVPWM linear range (WARNING lines) the twin's current is not regulated: offsets and
  gain errors are not followed, dead time dominates; every closed form (ideal regulation) is void.
So the fast engine is enough at regulated points where the ripple is well above the twin's
floor; near the limit, at low current or at a large current angle, check with --engine twin.
"""


def scatter(closed_pct: np.ndarray, twin_pct: np.ndarray, out: Path) -> tuple[Path, Path]:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 6))
    for j, op in enumerate(POINTS):
        ax.scatter(closed_pct[:, j], twin_pct[:, j], s=12, label=label(op))
    top = 1.05 * max(closed_pct.max(), twin_pct.max())
    ax.plot([0, top], [0, top], color="grey", linewidth=0.8, label="equal")
    ax.axvline(LIMIT_PCT, color="#cc3311", linestyle=":")
    ax.axhline(LIMIT_PCT, color="#cc3311", linestyle=":")
    ax.set_xlabel("closed form (bounds added), pk-pk % of mean torque")
    ax.set_ylabel("twin, pk-pk % of mean torque")
    ax.set_xlim(0, top)
    ax.set_ylim(0, top)
    ax.legend(fontsize=8)
    fig.tight_layout()
    paths = (out / "scatter.png", out / "scatter.svg")
    for path in paths:
        fig.savefig(path, dpi=120)
    plt.close(fig)
    return paths


if __name__ == "__main__":
    main()
