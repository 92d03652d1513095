"""Study: out-of-sample calibration of the PWM-switching, PWM-resolution (pk-pk and noise) and
word-length bands (issue 21 item 3; design.md §9).

Run: ``.venv/bin/python studies/pwm_calibration.py run OUT.json [--sets calibration holdout]``
then ``.venv/bin/python studies/pwm_calibration.py table OUT.json`` (the run takes ≈ 10 s per
motor × point × seed × plan on one core; ``--quick`` runs one point per set).

Each row runs the unmodified plan (``hil run --source S --seed N``) on the correct simulated
drive with a bench file whose ``[motor]`` and ``[operating_point]`` are the row's, and reads the
sealed record: each point's measured pk-pk against its prediction, the PWM-resolution noise
check's measured/predicted RMS and each plan's sensitivity slope. The measured figures come from
the twin through hil.analysis only; the predictions are hil.model's, used for the ratio and
nothing else.

The **calibration set** is Table I at four points (both directions) and seeds 0 and 1; the
**holdout set** is disjoint in motor, point and seed: two motors defined here (8 poles, 48 V,
L/R = 2.5 ms; 2 poles, 24 V, L/R = 0.3 ms — Table I is 4 poles, 12 V, L/R = 0.7 ms), two points
each (one reverse), seeds 5 and 6. A band is set on the calibration set and its holdout error
(the holdout ratios' excursion beyond the band, if any) is printed beside it.
"""

from __future__ import annotations

import argparse
import json
import math
import re
import subprocess
import sys
import tempfile
from pathlib import Path

EXAMPLE = Path(__file__).resolve().parents[1] / "hil" / "examples" / "sim-bench.toml"

#: Motors: [motor] tables of the bench file (Table I is the example's own).
MOTORS = {
    "table_i": None,
    # 8 poles, 48 V bus, L/R = 2.5 ms (Table I: 4 poles, 12 V, 0.7 ms)
    "octo_48v": {"model": "holdout A: 8-pole 48 V PMSM (simulated)", "pole_count": 8,
                 "dc_bus_v": 48.0, "phase_resistance_ohm": 0.12, "phase_inductance_h": 300e-6,
                 "max_reactance_ohm": 0.377, "ke_v_s_per_rad": 0.04,
                 "ke_definition": "rms_phase"},
    # 2 poles, 24 V bus, L/R = 0.3 ms
    "bipolar_24v": {"model": "holdout B: 2-pole 24 V PMSM (simulated)", "pole_count": 2,
                    "dc_bus_v": 24.0, "phase_resistance_ohm": 0.2, "phase_inductance_h": 60e-6,
                    "max_reactance_ohm": 0.019, "ke_v_s_per_rad": 0.03,
                    "ke_definition": "rms_phase"},
}
#: (motor, speed rpm, current A) points and seeds of each set; disjoint in all three.
SETS = {
    "calibration": {"points": [("table_i", 500.0, 20.0), ("table_i", 250.0, 10.0),
                               ("table_i", 1000.0, 30.0), ("table_i", -500.0, 20.0)],
                    "seeds": [0, 1]},
    "holdout": {"points": [("octo_48v", 600.0, 15.0), ("octo_48v", -900.0, 25.0),
                           ("bipolar_24v", 1200.0, 20.0), ("bipolar_24v", -700.0, 10.0)],
                "seeds": [5, 6]},
}
SOURCES = ("pwm_switching", "pwm_resolution", "word_length")


def bench_text(motor: str, speed_rpm: float, current_a: float) -> str:
    """The example bench file with this motor and operating point (nothing else changed)."""
    text = EXAMPLE.read_text()
    text = re.sub(r"(?m)^speed_rpm = 500\.0$", f"speed_rpm = {speed_rpm!r}", text)
    text = re.sub(r"(?m)^current_a = 20\.0$", f"current_a = {current_a!r}", text)
    table = MOTORS[motor]
    if table:
        body = "\n".join(f"{k} = {json.dumps(v)}" for k, v in table.items())
        text = re.sub(r"(?ms)^\[motor\].*?(?=^\[drive\])",
                      f"[motor]\nserial_number = \"SIM-MOTOR-{motor}\"\n{body}\n\n", text)
    return text


def run_one(source: str, motor: str, speed_rpm: float, current_a: float, seed: int,
            folder: Path) -> dict:
    """Run one plan on the simulated bench; its record's figures (see the module docstring)."""
    bench = folder / f"{motor}_{speed_rpm:g}_{current_a:g}.toml"
    bench.write_text(bench_text(motor, speed_rpm, current_a))
    args = [sys.executable, "-m", "hil", "run", "--bench", str(bench), "--source", source,
            "--seed", str(seed), "--no-report"]
    done = subprocess.run(args, capture_output=True, text=True, cwd=folder, timeout=1200)
    match = re.search(r"record: (\S+)", done.stdout + done.stderr)
    if not match:
        return {"error": (done.stdout + done.stderr)[-1500:]}
    return figures(folder / match.group(1), source)


def figures(record_dir: Path, source: str) -> dict:
    from hil.record import load_record

    record = load_record(record_dir)
    points = []
    for test in record["tests"]:
        verdict = test.get("verdict") or {}
        if test.get("source") != source or not verdict.get("predicted_pk_pk_pu"):
            continue
        measured = test["measured"]
        points.append({"injection": test["injection"], "outcome": test.get("outcome"),
                       "measured_pu": verdict["measured_pk_pk_pu"],
                       "predicted_pu": verdict["predicted_pk_pk_pu"],
                       "expanded_u_pu": measured["uncertainty"]["expanded_pu"]})
    sections = {k: v for k, v in record.items() if isinstance(v, dict)}
    sensitivity = (record.get("sensitivity") or sections.get("sections", {}).get("sensitivity")
                   or {}).get(source)
    noise = record.get("pwm_resolution_noise") or sections.get("sections", {}).get(
        "pwm_resolution_noise")
    outcomes = {t["test_id"].split("::")[-1]: t.get("outcome") for t in record["tests"]
                if t.get("test_id")}
    return {"points": points, "sensitivity": sensitivity, "noise": noise,
            "outcomes": outcomes}


def run(out: Path, sets, sources, quick: bool) -> None:
    results = json.loads(out.read_text()) if out.exists() else []
    done = {(r["set"], r["source"], r["motor"], r["speed_rpm"], r["current_a"], r["seed"])
            for r in results}
    with tempfile.TemporaryDirectory() as tmp:
        for name in sets:
            spec = SETS[name]
            points = spec["points"][:1] if quick else spec["points"]
            for source in sources:
                for motor, speed, current in points:
                    for seed in spec["seeds"][:1] if quick else spec["seeds"]:
                        key = (name, source, motor, speed, current, seed)
                        if key in done:
                            continue
                        row = {"set": name, "source": source, "motor": motor,
                               "speed_rpm": speed, "current_a": current, "seed": seed,
                               **run_one(source, motor, speed, current, seed, Path(tmp))}
                        results.append(row)
                        out.write_text(json.dumps(results, indent=1))
                        print(name, source, motor, speed, current, seed,
                              "error" if "error" in row else "ok", flush=True)


def ratios(rows, source: str, kind: str) -> list[tuple[str, float, float]]:
    """(label, measured/predicted, relative U) per point of ``source``; kind pk_pk or noise."""
    out = []
    for r in rows:
        if r["source"] != source or "error" in r:
            continue
        label = f"{r['motor']} {r['speed_rpm']:g} rpm {r['current_a']:g} A s{r['seed']}"
        if kind == "pk_pk":
            for p in r["points"]:
                knob = ",".join(f"{v:g}" for v in p["injection"].values())
                out.append((f"{label} {knob}", p["measured_pu"] / p["predicted_pu"],
                            p["expanded_u_pu"] / p["predicted_pu"]))
        elif kind == "noise" and r.get("noise"):
            for p in r["noise"]["points"]:
                out.append((f"{label} C={p['pwm_period_counts']}", p["ratio"],
                            p["expanded_uncertainty_pu"] / p["predicted_rms_pu"]))
        elif kind == "slope" and r.get("sensitivity"):
            s = r["sensitivity"]
            value = s.get("slope", s.get("exponent"))
            u = s.get("slope_u", s.get("exponent_u"))        # standard; k = 2 below
            if value is not None:
                out.append((label, float(value), 2.0 * float(u) if u is not None else math.nan))
    return out


def table(path: Path) -> None:
    rows = json.loads(path.read_text())
    for source, kind in (("pwm_switching", "pk_pk"), ("pwm_switching", "slope"),
                         ("pwm_resolution", "pk_pk"), ("pwm_resolution", "noise"),
                         ("pwm_resolution", "slope"), ("word_length", "pk_pk"),
                         ("word_length", "slope")):
        print(f"\n{source} {kind} (measured/predicted; U relative to the prediction)")
        for name in SETS:
            values = ratios([r for r in rows if r["set"] == name], source, kind)
            if not values:
                continue
            r = [v for _, v, _ in values]
            print(f"  {name:<11} n={len(r):3d}  min {min(r):.3f}  median "
                  f"{sorted(r)[len(r) // 2]:.3f}  max {max(r):.3f}")
            for label, value, u in values:
                print(f"      {label:<44} {value:7.3f}  ±{u:.3f}")
    print("\noutcomes of the correct drive's tests (per set and source)")
    for name in SETS:
        for source in SOURCES:
            counts: dict[str, int] = {}
            for r in rows:
                if r["set"] == name and r["source"] == source and "error" not in r:
                    for outcome in r["outcomes"].values():
                        counts[outcome] = counts.get(outcome, 0) + 1
            if counts:
                print(f"  {name:<11} {source:<15} {counts}")
    errors = [r for r in rows if "error" in r]
    for r in errors:
        print("ERROR", r["set"], r["source"], r["motor"], r["speed_rpm"], r["current_a"],
              r["error"][-300:])


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("mode", choices=("run", "table"))
    parser.add_argument("out", type=Path)
    parser.add_argument("--sets", nargs="+", default=list(SETS), choices=list(SETS))
    parser.add_argument("--sources", nargs="+", default=list(SOURCES), choices=SOURCES)
    parser.add_argument("--quick", action="store_true", help="one point and seed per set")
    args = parser.parse_args(argv)
    if args.mode == "run":
        run(args.out, args.sets, args.sources, args.quick)
    else:
        table(args.out)


if __name__ == "__main__":
    main()
