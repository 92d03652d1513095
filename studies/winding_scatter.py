"""Study: does the winding's type-A u cover the capture-to-capture scatter? (the recheck's
drift test rests on it; hil/characterisation/sampling.py)

Run: ``.venv/bin/python studies/winding_scatter.py [--captures 12] [--revolutions 8]
[--rate HZ]``. On the shipped simulated bench (Table I) at each point: the characterisation
stage, then ``--captures`` winding captures at the point (the recheck's capture), each identified
(``identify.winding``); printed: the scatter (std) of R over the captures against the mean u of
one capture (k = 1), the same for L, and the rate used. A scatter/u well above 1 means u
understates what a recheck sees, and the recheck calls noise a drift. ``--rate`` forces a rate
(e.g. 7919, the rate before ``sampling.sample_rate_hz``).
"""

from __future__ import annotations

import argparse
import tempfile

import numpy as np

POINTS = [(1200.0, 10.0), (500.0, 20.0), (250.0, 5.0), (-500.0, 20.0), (1600.0, 10.0)]


def scatter(speed_rpm: float, current_a: float, captures: int, revolutions: int,
            rate_hz: float | None) -> str:
    from dataclasses import replace

    from hil.bench import Bench
    from hil.characterisation.identify import winding
    from hil.characterisation.stage import (VOLTAGE_SKEW_BOUND_S, capture_plan, run_stage,
                                            voltage_capture)
    from hil.config import default_sim_bench
    from hil.record import RunRecord

    config = default_sim_bench().with_overrides(
        {"operating_point": {"speed_rpm": speed_rpm, "current_a": current_a}})
    bench = Bench.open(config, seed=5)
    record = RunRecord.create(tempfile.mkdtemp(), config, bench.identities())
    try:
        result = run_stage(bench, record)
        pole_pairs = config.motor.pole_pairs
        plan = capture_plan(result.point, pole_pairs, enabled=True, revolutions=revolutions)
        if rate_hz:
            plan = replace(plan, sample_rate_hz=rate_hz)
        found = [winding(voltage_capture(bench, record, f"scatter-{i}", plan, pole_pairs),
                         result.emf, pole_pairs, skew_bound_s=VOLTAGE_SKEW_BOUND_S)
                 for i in range(captures)]
    finally:
        record.finish("complete")
        bench.close()
    r = np.array([pair[0].value for pair in found])
    l_ = np.array([pair[1].value for pair in found])
    u_r = np.mean([pair[0].u for pair in found])
    u_l = np.mean([pair[1].u for pair in found])
    return (f"| {speed_rpm:g} | {current_a:g} | {plan.sample_rate_hz:g} | "
            f"{r.std(ddof=1) / u_r:.2f} | {l_.std(ddof=1) / u_l:.2f} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--captures", type=int, default=12)
    parser.add_argument("--revolutions", type=int, default=8)
    parser.add_argument("--rate", type=float, default=None)
    args = parser.parse_args()
    print("| speed rpm | current A | rate Hz | R: scatter / u | L: scatter / u |")
    print("|---|---|---|---|---|")
    for speed_rpm, current_a in POINTS:
        print(scatter(speed_rpm, current_a, args.captures, args.revolutions, args.rate),
              flush=True)


if __name__ == "__main__":
    main()
