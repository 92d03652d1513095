"""Calibration of the self-check's DAQ time-base bands (issue 30 item 4; hil.daq_timebase).

Each row is one self-check capture as the simulated DAQ takes it (the twin of the row's bench
file at its operating point, settle, carrier valley, 7919 Hz, 8.25 electrical revolutions,
``drivers.simulated.modbus_daq_server.sample_timing`` for the DAQ's instants) on a correct drive
and with the two DAQ defects (clock 0.5 % slow, instants jittering by ±3/8 sample). The
**calibration set** is Table I at four points, seeds 0 and 1; the **holdout set** is disjoint in
motor, point and seed (the validity study's other motors). The bands are set on the calibration
set only (rule below) and then checked on the holdout set, with the defects, and written to
``hil/model/README.md`` ("DAQ time base").

Rules (set before the holdout was run):
* clock: |c − 1| ≤ 2 × the calibration set's largest + 100 ppm (a PWM crystal's and a DAQ
  clock's ±50 ppm each, which the twin, whose clocks are exact, cannot show);
* PWM line share ≥ ½ × the calibration set's smallest;
* encoder second difference RMS ≤ 1 count: a quantised ramp's second difference is −1, 0 or +1
  (theory; the sets check it holds with the dyno holding speed).

Run: ``.venv/bin/python studies/daq_timebase_calibration.py [--out FILE.md]`` (≈ 1-2 min).
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
import validity as study  # noqa: E402  (the validity study's motors and bench copies)

from hil.capture import Capture  # noqa: E402
from hil.config import load_bench  # noqa: E402
from hil.daq_timebase import encoder_second_difference_rms, pwm_line  # noqa: E402
from hil.sim.defects import DriveDefects  # noqa: E402
from hil.sim.twin import DriveTwin  # noqa: E402
from hil.simbench import twin_config  # noqa: E402
from ripple_hil_drivers.simulated.modbus_daq_server import sample_timing  # noqa: E402
from ripple_hil_testplans.conditions import SELF_CHECK_SAMPLE_RATE_HZ  # noqa: E402

RATE_HZ = SELF_CHECK_SAMPLE_RATE_HZ
PWM_HZ = 20_000.0
COUNTS_PER_REV = 7200
SETS = {
    "calibration": {"motors": ["table_i"], "seeds": [0, 1],
                    "points": [(500.0, 20.0), (-500.0, 20.0), (250.0, 10.0), (1000.0, 5.0)]},
    "holdout": {"motors": ["p8_48v", "p2_24v", "p10_48v", "p12_48v", "p14_48v"], "seeds": [5],
                "points": [(800.0, 15.0), (-600.0, 12.0), (300.0, 5.0), (-400.0, 12.0)]},
}
DEFECTS = {"correct": {}, "clock 0.5 % slow": {"daq_clock_scale": 0.995},
           "jitter ±3/8 sample": {"daq_sample_jitter_samples": 0.375}}


def capture(motor: str, speed_rpm: float, current_a: float, seed: int, defects: dict,
            folder: Path) -> tuple[Capture, int]:
    """One self-check capture of the row (module docstring)."""
    bench = load_bench(study.bench_copy(motor, speed_rpm, current_a, folder))
    config = replace(twin_config(bench), speed_rpm=speed_rpm, current_command_a=current_a)
    twin = DriveTwin(config, seed=seed, defects=DriveDefects(**defects))
    twin.enable()
    twin.advance(0.05, RATE_HZ, channels=())
    twin.advance_to_carrier_valley()
    pole_pairs = bench.motor.pole_pairs
    n = int(8.25 / (abs(speed_rpm) / 60.0 * pole_pairs) * RATE_HZ)
    ticks = np.arange(n)
    timing = sample_timing(twin, ticks)
    extra = 1 if timing.oversample > 1 else 0
    data = twin.advance((n + extra) / (RATE_HZ * timing.clock),
                        RATE_HZ * timing.clock * timing.oversample,
                        channels=["ia_a", "ib_a", "rotor_angle_mech_rad"])
    channels = {k: np.asarray(data[k])[timing.index]
                for k in ("ia_a", "ib_a", "rotor_angle_mech_rad")}
    return Capture({"time_s": ticks / RATE_HZ, **channels},
                   meta={"pole_pairs": pole_pairs}), pole_pairs


def rows_of(name: str, folder: Path) -> list[dict]:
    spec, rows = SETS[name], []
    for motor in spec["motors"]:
        for speed, current in spec["points"]:
            for seed in spec["seeds"]:
                for label, defects in DEFECTS.items():
                    try:
                        cap, pole_pairs = capture(motor, speed, current, seed, defects, folder)
                    except Exception as exc:  # noqa: BLE001 - a point the twin refuses
                        print(f"{name} {motor} {speed:g}/{current:g}: {exc}", file=sys.stderr)
                        continue
                    line = pwm_line(cap, PWM_HZ, pole_pairs, RATE_HZ)      # NaN: no check
                    rms, per_sample = encoder_second_difference_rms(cap, COUNTS_PER_REV)
                    rows.append({"set": name, "motor": motor, "speed_rpm": speed,
                                 "current_a": current, "seed": seed, "case": label,
                                 "clock_ppm": (line.clock_scale - 1.0) * 1e6,
                                 "line_share": line.line_share, "encoder_rms": rms,
                                 "counts_per_sample": per_sample})
    return rows


def within_region(row: dict) -> dict:
    """A row's PWM-line figures as the check reads them: none above ``MAX_LINE_ELEC_HZ``."""
    from hil.daq_timebase import MAX_LINE_ELEC_HZ

    pole_pairs = study.motor_parameters(row["motor"]).pole_pairs
    if abs(row["speed_rpm"]) / 60.0 * pole_pairs > MAX_LINE_ELEC_HZ:
        return row | {"clock_ppm": float("nan"), "line_share": float("nan")}
    return row


def bands(calibration: list[dict]) -> dict:
    correct = [r for r in calibration if r["case"] == "correct" and np.isfinite(r["clock_ppm"])]
    return {"clock_tolerance_ppm": 2 * max(abs(r["clock_ppm"]) for r in correct) + 100.0,
            "min_line_share": 0.5 * min(r["line_share"] for r in correct),
            "max_encoder_rms_counts": 1.0}


def table(rows: list[dict], b: dict) -> str:
    lines = ["| set | case | rows (line judged) | clock ppm (min..max) | line share (min..max) | "
             "encoder RMS counts (min..max) | caught by clock / share / encoder |",
             "|---|---|---|---|---|---|---|"]
    for name in SETS:
        for case in DEFECTS:
            sel = [r for r in rows if r["set"] == name and r["case"] == case]
            share_judged = [r["line_share"] for r in sel if np.isfinite(r["line_share"])]
            if not sel:
                continue
            clock = [r["clock_ppm"] for r in sel]
            share = share_judged or [float("nan")]
            enc = [r["encoder_rms"] for r in sel]
            judged = [c for c in clock if np.isfinite(c)]
            clock = judged or [float("nan")]
            caught = (sum(abs(c) > b["clock_tolerance_ppm"] for c in judged),
                      sum(s < b["min_line_share"] for s in share if np.isfinite(s)),
                      sum(e > b["max_encoder_rms_counts"] for e in enc))
            lines.append(f"| {name} | {case} | {len(sel)} ({len(judged)}) | "
                         f"{min(clock):.3g}..{max(clock):.3g} "
                         f"| {min(share):.3f}..{max(share):.3f} | {min(enc):.3f}..{max(enc):.3f}"
                         f" | {caught[0]} / {caught[1]} / {caught[2]} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    import tempfile

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path)
    parser.add_argument("--from-json", type=Path,
                        help="re-judge the rows of an earlier run (FILE.json) with the current "
                             "region (MAX_LINE_ELEC_HZ) instead of running them again")
    args = parser.parse_args(argv)
    if args.from_json:
        rows = [within_region(r) for r in json.loads(args.from_json.read_text())["rows"]]
        calibration = [r for r in rows if r["set"] == "calibration"]
        holdout = [r for r in rows if r["set"] == "holdout"]
        b = bands(calibration)
    else:
        with tempfile.TemporaryDirectory() as tmp:
            calibration = rows_of("calibration", Path(tmp))
            b = bands(calibration)
            holdout = rows_of("holdout", Path(tmp))
    text = (f"Bands from the calibration set: clock ±{b['clock_tolerance_ppm']:.1f} ppm, line "
            f"share ≥ {b['min_line_share']:.3f}, encoder RMS ≤ {b['max_encoder_rms_counts']:g} "
            f"count\n\n" + table(calibration + holdout, b))
    print(text)
    if args.out:
        args.out.write_text(text + "\n")
        args.out.with_suffix(".json").write_text(json.dumps(
            {"bands": b, "rows": calibration + holdout}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
