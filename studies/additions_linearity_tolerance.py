"""Study: how far the two addition sizes' transfers differ on CORRECT twin drives — the
calibration of the standard-additions linearity tolerance (hil.diagnosis.additions
``LINEARITY_TOLERANCE``).

Run: ``.venv/bin/python studies/additions_linearity_tolerance.py [--drives 6] [--seed 0]
[--pole-count 4]``.

Each drive gets random faults of its own (the draws of ``studies/additions_coverage.py``: offsets
±0.3 A, gains ±2 %, dead time 0-2 µs, one cogging term), and the diagnosis plan's two-size
additions at +1000 rpm, 20 A (``testplans/diagnosis_design.py``: +0.2/+0.4 A on each sensor,
+1/+2 % gain on sensor a) are simulated against the base. Printed per addition: the largest
relative magnitude difference |(|H₂| − |H₁|)|/|H̄| and phase difference |∠H₂ − ∠H₁| (degrees)
between the transfers of the two sizes, net of nothing (type A included: an upper bound of the
drive's own departure from a straight line); and each offset and gain transfer of the plan's
design against the forward model of its addition (``compare_transfers_with_models``: the
relative vector difference, the calibration of ``MODEL_TOLERANCE_REL``). Calibration: Table I motor (pole count 4), seed 0;
holdout: other motors and seeds (README of hil/diagnosis, "linearity tolerance").
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from hil.diagnosis import additions as A
from hil.diagnosis.additions_proof import simulate_additions
from hil.diagnosis.orders import spectrum_from_capture
from hil.diagnosis.twin_proof import twin_setup
from hil.motor import MotorParameters
from hil.sim import DriveConfig, Injection, MotorModel
from ripple_hil_testplans import diagnosis_design as design
from studies.additions_coverage import draw

KEYS = ("addition_ia_offset_a", "addition_ib_offset_a", "addition_gain_a_pu")


def runs() -> list:
    two = [(s, i, k, v) for s, i, k, v in design.ADDITIONS if (s, i) == (1000.0, 20.0)
           and k in KEYS]
    return [(1000.0, 20.0, None, 0.0)] + two


def model_departures(pairs, config) -> dict:
    """(point, key) -> |H_measured − H_model|/|H_model| (the transfer-vs-model comparison's
    relative vector difference, type A included) for the offsets' and the gain's transfers."""
    result = A.diagnose_by_additions(pairs, setup=twin_setup(config), max_mech_order=32)
    checks = A.compare_transfers_with_models(result, twin_setup(config),
                                             config.transducer.accuracy_class_pct)
    return {(c["point"], c["addition"]): abs(c["measured"] - c["model"]) / abs(c["model"])
            for c in checks if c["addition"] in KEYS and c.get("compared", True)}


def model_runs() -> list:
    """The plan's other offset and gain addition points and their bases (transfer vs model)."""
    other = [(s, i, k, v) for s, i, k, v in design.ADDITIONS if (s, i) != (1000.0, 20.0)
             and k in KEYS]
    return [(s, i, None, 0.0) for s, i in sorted({(s, i) for s, i, _, _ in other})] + other


def differences(pairs, pole_pairs: int) -> dict:
    """key -> (relative magnitude difference, phase difference in degrees)."""
    spectra = [A.with_addition(spectrum_from_capture(c, current_a=op["current_a"],
                                                     max_mech_order=32, label=op["label"]), op)
               for c, op in pairs]
    base = spectra[0]
    out = {}
    for key in KEYS:
        kind = A._BY_KEY[key]
        m = pole_pairs * kind.elec_order
        sized = sorted(((kind.effective(s.meta["addition"]["value"]), s) for s in spectra[1:]
                        if s.meta["addition"]["key"] == key), key=lambda e: abs(e[0]))
        h = [(s.coefficients_nm[m] - base.coefficients_nm[m]) / d for d, s in sized]
        mean = abs(h[0] + h[-1]) / 2.0
        out[key] = (abs(abs(h[-1]) - abs(h[0])) / mean,
                    abs(math.degrees(np.angle(h[-1] / h[0]))))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--drives", type=int, default=6)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--pole-count", type=int, default=4)
    parser.add_argument("--linearity-only", action="store_true",
                        help="only the +1000 rpm, 20 A two-size points (no transfer vs model "
                             "at the plan's other addition points)")
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    worst = {key: [0.0, 0.0, 0.0] for key in KEYS}
    started = time.time()
    for drive in range(args.drives):
        faults, cogging = draw(rng)
        motor = MotorModel(parameters=MotorParameters(pole_count=args.pole_count),
                           cogging=cogging)
        config = DriveConfig(injection=Injection(**faults), motor=motor)
        all_runs = runs() + ([] if args.linearity_only else model_runs())
        pairs = simulate_additions(config, all_runs, revolutions_elec=design.REVOLUTIONS_ELEC,
                                   sample_rate_hz=design.SAMPLE_RATE_HZ,
                                   settle_s=design.SETTLE_S, seed=args.seed * 10_000 + drive)
        for key, (rel, deg) in differences(pairs[:len(runs())], args.pole_count // 2).items():
            worst[key][:2] = [max(worst[key][0], rel), max(worst[key][1], deg)]
            print(f"drive {drive}: {key:<22} |Δ|H||/|H| {100 * rel:6.3f} %  |Δ∠H| {deg:5.2f}°",
                  flush=True)
        if not args.linearity_only:
            for (point, key), rel in model_departures(pairs, config).items():
                worst[key][2] = max(worst[key][2], rel)
                print(f"drive {drive}: {key:<22} at {point}: |H − model|/|model| "
                      f"{100 * rel:6.2f} %", flush=True)
    print(f"{args.drives} drives, pole count {args.pole_count}, seed {args.seed}, "
          f"{time.time() - started:.0f} s; largest:")
    for key, (rel, deg, model) in worst.items():
        print(f"  {key:<22} two sizes: magnitude {100 * rel:.3f} %, phase {deg:.2f}°; "
              + ("transfer vs model not run" if args.linearity_only else
                 f"transfer vs model {100 * model:.2f} %"))


if __name__ == "__main__":
    main()
