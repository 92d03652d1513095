"""Validity study (issue 21 item 9): a CORRECT simulated drive over several motors and operating
points, every plan, run as a user would.

For each motor (Table I and two very different ones: pole count, bus voltage, L/R, Ke stated
another way) and each operating point (both directions, low current, near the voltage limit) a copy
of ``hil/examples/sim-bench.toml`` is written with that ``[motor]`` and ``[operating_point]``,
and ``python -m hil run --bench COPY --no-report`` runs every plan on the unmodified simulated
drive. Each test of the record is then one of:

- ``pass``: judged and accepted;
- ``wrong rejection``: judged and failed — the drive is correct, so the plan is wrong there;
- ``not determinable``: refused by its plan's validity region (hil.validity) before the bench was
  touched, or a check its sweep could not resolve (the reason is kept);
- ``measured``: no verdict to give (diagnosis and ripple-map points, references);
- ``error``: the test raised.

Run: ``.venv/bin/python studies/validity.py [--reduced] [--motor NAME] [--point RPM,A]
[--shuffle SEED] [--deviation NAME|all] [--out DIR]`` (the full grid: 6 motors × 12 points, ≈ 15-30 s per point on one
core; ``--reduced``: 2 runs for CI).
``--dask`` runs the points as a regression grid (``hil campaign``'s engine, hil/campaign/grid.py)
on an embedded LocalCluster (``--workers N``) or an existing cluster (``--scheduler ADDRESS``):
resumable in ``OUT/grid`` (a rerun skips the points done), every record sealed and indexed in
``OUT/grid/results.sqlite``; the table is the same.
``--deviation`` (issue 29) runs each point on a motor, loop and transducer that are *not* what the
bench file states (``[simulation.actual]``, hil/actual.py, as multiples of each motor's own
nameplate: ``DEVIATIONS``) at the six ``DEVIATION_POINTS``; the bench file keeps the nameplate,
so the characterisation stage must find the difference. Still a correct drive: any failure is a
wrong rejection.
Writes ``DIR/validity.json`` and ``DIR/validity.md`` and prints the table (``--from-json FILE``
prints it again); exit 1 on a wrong rejection.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
import tomllib
from collections import Counter
from pathlib import Path

import tomli_w

from hil.config import example_bench_path
from hil.motor import MotorParameters
from hil.outcome_kinds import MEASURED, NOT_DETERMINABLE_PREFIX

#: The motors: the bench file's ``[motor]`` table of each (Table I: the shipped bench's own).
MOTORS: dict[str, dict] = {
    "table_i": {},
    # 8 poles, 48 V, L/R = 2.5 ms (Table I: 4 poles, 12 V, 0.7 ms), Ke per RMS phase
    "p8_48v": {"model": "8-pole 48 V PMSM (study)", "serial_number": "STUDY-P8", "pole_count": 8,
               "dc_bus_v": 48.0, "phase_resistance_ohm": 0.12, "phase_inductance_h": 0.3e-3,
               "max_reactance_ohm": 0.4, "ke_v_s_per_rad": 0.06, "ke_definition": "rms_phase"},
    # 2 poles, 24 V, L/R = 0.25 ms, Ke stated peak line-to-line
    "p2_24v": {"model": "2-pole 24 V PMSM (study)", "serial_number": "STUDY-P2", "pole_count": 2,
               "dc_bus_v": 24.0, "phase_resistance_ohm": 0.4, "phase_inductance_h": 0.1e-3,
               "max_reactance_ohm": 0.1, "ke_v_s_per_rad": 0.08, "ke_definition": "peak_line"},
    # issue 30: pole counts whose count order is not an integer with the 7200-count encoder
    # (10 poles: 57.6 per electrical revolution at decimation 25; 14 poles: 288/7), and 12 poles
    # (48 counts: divides), all 48 V; Ke per RMS phase
    "p10_48v": {"model": "10-pole 48 V PMSM (study)", "serial_number": "STUDY-P10",
                "pole_count": 10, "dc_bus_v": 48.0, "phase_resistance_ohm": 0.12,
                "phase_inductance_h": 0.4e-3, "max_reactance_ohm": 0.5, "ke_v_s_per_rad": 0.05,
                "ke_definition": "rms_phase"},
    "p12_48v": {"model": "12-pole 48 V PMSM (study)", "serial_number": "STUDY-P12",
                "pole_count": 12, "dc_bus_v": 48.0, "phase_resistance_ohm": 0.08,
                "phase_inductance_h": 0.25e-3, "max_reactance_ohm": 0.4, "ke_v_s_per_rad": 0.05,
                "ke_definition": "rms_phase"},
    "p14_48v": {"model": "14-pole 48 V PMSM (study)", "serial_number": "STUDY-P14",
                "pole_count": 14, "dc_bus_v": 48.0, "phase_resistance_ohm": 0.1,
                "phase_inductance_h": 0.3e-3, "max_reactance_ohm": 0.5, "ke_v_s_per_rad": 0.04,
                "ke_definition": "peak_phase"},
}
#: Fixed points (speed rpm, peak current A) of every motor; two near the voltage limit are added.
FIXED_POINTS = [(500.0, 20.0), (250.0, 10.0), (800.0, 15.0), (1500.0, 30.0), (-800.0, 15.0),
                (-500.0, 20.0), (1000.0, 5.0), (250.0, 5.0), (-250.0, 10.0), (1200.0, 10.0)]
#: The near-limit points run at this fraction of the speed where 20 A reaches V_dc/√3.
NEAR_LIMIT_FRACTION = 0.9
NEAR_LIMIT_CURRENT_A = 20.0
#: The reduced grid (CI): a reverse point on Table I and a forward one on the 8-pole motor.
REDUCED = [("table_i", (-500.0, 20.0)), ("p8_48v", (800.0, 15.0))]
#: A run's own time limit, s.
RUN_TIMEOUT_S = 1200.0

#: Actual-vs-nameplate deviation sets (issue 29): multiples of the bench file's [motor] R, L, Ke,
#: [drive] loop bandwidth and [torque] bandwidth; ``l_sat_at`` puts the saturation current at that
#: multiple of ``SATURATION_REFERENCE_A`` (L(|i|) = L/(1 + (|i|/i_sat)²): 2 → L × 0.8 at 20 A,
#: × 0.985 at 5 A; relative to the point's current it made a 5 A point's motor saturate to
#: L × 0.2 at the 20 A other plans use, and its loop, tuned on the nameplate, went unstable);
#: ``warming_pu``: the winding's steady rise at ``SATURATION_REFERENCE_A`` (τ = ``WARMING_TAU_S``;
#: copper loss ∝ I², so a 5 A point's winding warms 1.25 % by itself and 20 % while the plans
#: drive 20 A — set at the point's current, a 5 A point's winding rose 320 % (R × 4.2, some
#: +800 K) while the diagnosis plan drove 20 A: not a motor).
DEVIATIONS: dict[str, dict] = {
    "warm_saturated": {"r": 1.30, "l": 1.00, "l_sat_at": 2.0, "ke": 0.96},
    "hot_slow": {"r": 1.45, "l": 0.70, "ke": 0.92, "loop": 0.80, "transducer": 0.70},
    "cold_fast": {"r": 0.85, "l": 1.15, "ke": 1.04, "loop": 1.25, "transducer": 1.40},
    "warming": {"r": 1.00, "l": 1.00, "l_sat_at": 3.0, "ke": 0.98, "loop": 1.10,
                "transducer": 0.85, "warming_pu": 0.20},
}
#: The current (peak A) at which ``l_sat_at`` is set: the study's high-current points'.
SATURATION_REFERENCE_A = 20.0
#: The winding's thermal time constant of the warming set, s (a run's captures last seconds)
WARMING_TAU_S = 2.0
#: Six points per motor for the deviation axis: both directions, low and high current, near
#: the voltage limit (the last two are ± the near-limit speed, added by ``deviation_grid``).
DEVIATION_POINTS = [(500.0, 20.0), (-500.0, 20.0), (250.0, 5.0), (1200.0, 10.0)]
#: The deviation axis's motors: Table I, 8 poles 48 V, 10 poles (count order not whole)
DEVIATION_MOTORS = ["table_i", "p8_48v", "p10_48v"]

PASS, WRONG, NOT_DET, ERROR = "pass", "wrong rejection", "not determinable", "error"


def motor_parameters(name: str) -> MotorParameters:
    base = _base_bench()["motor"]
    table = base | MOTORS[name]
    keys = {f for f in MotorParameters.__dataclass_fields__}
    return MotorParameters(**{k: v for k, v in table.items() if k in keys})


def near_limit_speed_rpm(motor: MotorParameters, speed_limit_rpm: float) -> float:
    """``NEAR_LIMIT_FRACTION`` of the forward speed at which ``NEAR_LIMIT_CURRENT_A`` needs
    V_dc/√3 (the motoring phasor), within the bench's speed limit."""
    from hil.model import OperatingPoint

    top = OperatingPoint(speed_rpm=1.0, current_a=NEAR_LIMIT_CURRENT_A,
                         motor=motor).voltage_limited_speed_rpm()
    return float(round(min(NEAR_LIMIT_FRACTION * top, 0.97 * speed_limit_rpm)))


def grid(name: str) -> list[tuple[float, float]]:
    """The motor's operating points: the fixed ones and ± the near-limit speed at 20 A."""
    limit = _base_bench()["limits"]["speed_rpm"]
    near = near_limit_speed_rpm(motor_parameters(name), limit)
    return FIXED_POINTS + [(near, NEAR_LIMIT_CURRENT_A), (-near, NEAR_LIMIT_CURRENT_A)]


def deviation_grid(name: str) -> list[tuple[float, float]]:
    """The deviation axis's points of a motor: ``DEVIATION_POINTS`` and ± the near-limit speed."""
    near = grid(name)[-2:]
    return DEVIATION_POINTS + near


def actual_table(table: dict, deviation: str) -> dict:
    """``[simulation.actual]`` of ``DEVIATIONS[deviation]`` on the bench ``table`` (its stated
    [motor], [drive], [torque]); the same at every operating point of the motor."""
    dev = DEVIATIONS[deviation]
    motor, drive, torque = table["motor"], table["drive"], table["torque"]
    actual = {"phase_resistance_ohm": motor["phase_resistance_ohm"] * dev["r"],
              "phase_inductance_h": motor["phase_inductance_h"] * dev["l"],
              "ke_v_s_per_rad": motor["ke_v_s_per_rad"] * dev["ke"]}
    if "l_sat_at" in dev:
        actual["saturation_current_a"] = dev["l_sat_at"] * SATURATION_REFERENCE_A
    if "loop" in dev:
        actual["current_loop_bandwidth_hz"] = drive["current_loop_bandwidth_hz"] * dev["loop"]
    if "transducer" in dev:
        actual["bandwidth_hz"] = torque["bandwidth_hz"] * dev["transducer"]
    if "warming_pu" in dev:
        actual["winding_time_constant_s"] = WARMING_TAU_S
        actual["winding_rise_pu_per_a2"] = dev["warming_pu"] / SATURATION_REFERENCE_A ** 2
    return actual


def _base_bench() -> dict:
    return tomllib.loads(example_bench_path("sim-bench").read_text())


def bench_table(name: str, speed_rpm: float, current_a: float,
                deviation: str | None = None) -> dict:
    """The shipped simulated bench with this motor and operating point (a TOML table); with
    ``deviation``, its physics moved away from that nameplate (``actual_table``)."""
    table = _base_bench()
    table["motor"] = table["motor"] | MOTORS[name]
    table["operating_point"] = {"speed_rpm": speed_rpm, "current_a": current_a,
                                "current_angle_deg": 0.0}
    if deviation is not None:
        simulation = table.setdefault("simulation", {})
        simulation["actual"] = actual_table(table, deviation)
    return table


def bench_copy(name: str, speed_rpm: float, current_a: float, folder: Path,
               deviation: str | None = None) -> Path:
    """A copy of the shipped simulated bench with this motor, operating point and deviation."""
    path = folder / f"bench-{name}-{speed_rpm:g}rpm-{current_a:g}A.toml"
    path.write_text(tomli_w.dumps(bench_table(name, speed_rpm, current_a, deviation)))
    return path


def classify(test: dict) -> tuple[str, str | None]:
    """One record test → (category, reason) (module docstring)."""
    outcome, message = test.get("outcome"), test.get("message") or test.get("error")
    if outcome == "passed":
        # the record says "measured, no verdict" for a point without a rule; a test that passed
        # asserted something (e.g. the diagnosis plan's fit and standard additions)
        return PASS, None
    if outcome in ("not determinable", MEASURED):
        return (NOT_DET, message) if outcome != MEASURED else (MEASURED, None)
    if outcome == "skipped":
        reason = message or ""
        if reason.startswith(NOT_DETERMINABLE_PREFIX):
            reason = reason[len(NOT_DETERMINABLE_PREFIX):]
        return NOT_DET, reason
    if outcome == "failed":
        return WRONG, message
    return ERROR, message


def plan_order(seed: int, sources=()) -> list[str]:
    """The plans (``sources``, else every plan ``hil run`` knows) in a random order drawn with
    ``seed``: ``hil run`` runs its ``--source`` plans in the order given (the self-check always
    first: a failed self-check voids the rest), so state one plan leaves behind meets others."""
    import random

    from hil.commands.run import SELF_CHECK, plan_modules

    names = [n for n in (sources or plan_modules()) if n != SELF_CHECK]
    random.Random(seed).shuffle(names)
    return names


def run_point(name: str, speed_rpm: float, current_a: float, folder: Path,
              sources=(), deviation: str | None = None) -> dict:
    """One ``hil run`` on the correct simulated drive; the classified tests of its record."""
    folder.mkdir(parents=True, exist_ok=True)
    bench = bench_copy(name, speed_rpm, current_a, folder, deviation)
    records = folder / "records"
    args = [sys.executable, "-m", "hil", "run", "--bench", str(bench), "--no-report",
            "--record-dir", str(records)]
    for source in sources:
        args += ["--source", source]
    started = time.perf_counter()
    done = subprocess.run(args, capture_output=True, text=True, timeout=RUN_TIMEOUT_S,
                          cwd=folder)
    row = {"motor": name, "speed_rpm": speed_rpm, "current_a": current_a,
           "deviation": deviation, "exit_status": done.returncode, "seconds": round(time.perf_counter() - started, 1),
           "tests": []}
    # record folders only (the results database's file and lock sit beside them)
    found = sorted(p for p in records.iterdir() if p.is_dir()) if records.exists() else []
    if not found:
        row["run_error"] = (done.stdout[-1500:] + done.stderr[-1500:]).strip()
        return row
    row["tests"] = classified_tests(found[-1])
    return row


def classified_tests(record: Path) -> list[dict]:
    from hil.record import load_record

    tests = []
    for test in load_record(record)["tests"]:
        category, reason = classify(test)
        tests.append({"test_id": test.get("test_id"), "source": test.get("source"),
                      "category": category, "reason": reason})
    return tests


def _entries(plan):
    """``plan``'s (motor, (rpm, A), deviation or None) whatever its entries' length."""
    return [(entry[0], entry[1], entry[2] if len(entry) > 2 else None) for entry in plan]


def run_on_dask(plan, sources, folder: Path, scheduler: str | None,
                workers: int | None) -> list[dict]:
    """The same runs as a regression grid (``hil campaign``'s engine: resumable in ``folder``,
    each record sealed and indexed in ``folder/results.sqlite``); the same rows."""
    from hil.campaign.grid import run_grid
    from hil.campaign.grid_spec import GridRun

    runs = [GridRun({"motor": name, "point": f"{speed:g}rpm_{current:g}A"}
                    | ({"deviation": deviation} if deviation else {}),
                    bench_table(name, speed, current, deviation), tuple(sources), 0,
                    RUN_TIMEOUT_S)
            for name, (speed, current), deviation in _entries(plan)]
    result = run_grid(runs, folder, scheduler=scheduler, n_workers=workers,
                      results_db=f"sqlite:///{(folder / 'results.sqlite').resolve()}",
                      progress=sys.stderr.isatty())
    print(f"grid: {len(result.computed)} run(s) computed on {result.workers} worker(s), "
          f"{len(result.skipped)} resumed, wall {result.wall_s:.0f} s", file=sys.stderr)
    rows = []
    for (name, (speed, current), deviation), grid in zip(_entries(plan), result.rows):
        row = {"motor": name, "speed_rpm": speed, "current_a": current, "deviation": deviation,
               "exit_status": grid.get("exit_status"), "seconds": grid.get("seconds"),
               "tests": []}
        if grid["state"] == "done":
            row["tests"] = classified_tests(Path(grid["record"]))
        else:
            row["run_error"] = grid.get("output") or grid["state"]
        rows.append(row)
    return rows


def counts(row: dict) -> Counter:
    return Counter(t["category"] for t in row["tests"])


def model_points(rows: list[dict]) -> Counter:
    """Categories of the model-validation points (injected sources' sweep points)."""
    injected = {"encoder", "word_length", "dc_offset", "gain_mismatch", "pwm_resolution",
                "pwm_switching", "dead_time"}
    return Counter(t["category"] for row in rows for t in row["tests"]
                   if t["source"] in injected and "sensitivity" not in (t["test_id"] or "")
                   and "noise" not in (t["test_id"] or "")
                   and "_scale" not in (t["test_id"] or ""))


def markdown(rows: list[dict]) -> str:
    lines = ["| motor | speed rpm | current A | deviation | pass | wrong rejection | "
             "not determinable | measured | error | exit |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for row in rows:
        c = counts(row)
        lines.append(f"| {row['motor']} | {row['speed_rpm']:g} | {row['current_a']:g} | "
                     f"{row.get('deviation') or 'as stated'} | "
                     f"{c[PASS]} | {c[WRONG]} | {c[NOT_DET]} | {c[MEASURED]} | {c[ERROR]} | "
                     f"{row['exit_status']}{' (no record)' if 'run_error' in row else ''} |")
    total = Counter()
    for row in rows:
        total += counts(row)
    lines.append(f"| **all** | | | | {total[PASS]} | {total[WRONG]} | {total[NOT_DET]} | "
                 f"{total[MEASURED]} | {total[ERROR]} | |")
    model = model_points(rows)
    judged = model[PASS] + model[WRONG]
    share = judged / max(1, judged + model[NOT_DET] + model[ERROR])
    lines += ["", f"Model-validation points: {judged} judged ({model[PASS]} pass, "
                  f"{model[WRONG]} wrong rejections), {model[NOT_DET]} not determinable, "
                  f"{model[ERROR]} errors: {100 * share:.0f} % judged.", ""]
    lines += ["| plan | pass | wrong rejection | not determinable | measured | error |",
              "|---|---|---|---|---|---|"]
    per_plan: dict[str, Counter] = {}
    for row in rows:
        for t in row["tests"]:
            per_plan.setdefault(t["source"] or "?", Counter())[t["category"]] += 1
    lines += [f"| {plan} | {c[PASS]} | {c[WRONG]} | {c[NOT_DET]} | {c[MEASURED]} | {c[ERROR]} |"
              for plan, c in sorted(per_plan.items())]
    lines.append("")
    bad = [(row, t) for row in rows for t in row["tests"] if t["category"] in (WRONG, ERROR)]
    if bad:
        lines += ["Wrong rejections and errors:", ""]
        lines += [f"- {row['motor']} {row['speed_rpm']:g} rpm {row['current_a']:g} A "
                  f"{row.get('deviation') or ''}: "
                  f"`{t['test_id']}` {t['category']}: {(t['reason'] or '')[:300]}"
                  for row, t in bad]
    reasons = Counter((t["source"], _reason_kind(t["reason"])) for row in rows
                      for t in row["tests"] if t["category"] == NOT_DET)
    if reasons:
        lines += ["", "Not determinable, by plan and limit:", "",
                  "| plan | limit | tests |", "|---|---|---|"]
        lines += [f"| {source} | {kind} | {n} |" for (source, kind), n in sorted(reasons.items())]
    runs = [row for row in rows if "run_error" in row]
    if runs:
        lines += ["", "Runs without a record:", ""]
        lines += [f"- {r['motor']} {r['speed_rpm']:g}/{r['current_a']:g}: "
                  f"{r['run_error'][-300:]}" for r in runs]
    return "\n".join(lines)


def _reason_kind(reason: str | None) -> str:
    """The limit a not-determinable reason names (its words before the first colon)."""
    return (reason or "?").split(":")[0][:60]


def with_base(row: dict, base_json: Path, sources: set[str]) -> dict:
    """``row`` (a run of only ``sources``) completed with the other plans' tests of the same
    motor, point and deviation in an earlier full study (``base_json``), kept as they were."""
    rows = json.loads(base_json.read_text())["rows"]
    key = ("motor", "speed_rpm", "current_a", "deviation")
    for base in rows:
        if all(base.get(name) == row.get(name) for name in key):
            kept = [t for t in base["tests"] if t["source"] not in sources]
            rerun = [t for t in row["tests"] if t["source"] in sources]
            return {**row, "tests": kept + rerun,
                    "rerun": f"{', '.join(sorted(sources))} re-run; other plans from "
                             f"{base_json.name}"}
    raise SystemExit(f"{base_json}: no row for {row['motor']} {row['speed_rpm']:g} rpm "
                     f"{row['current_a']:g} A (deviation {row.get('deviation')})")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reduced", action="store_true", help="the small CI grid")
    parser.add_argument("--out", type=Path, default=Path("validity-study"))
    parser.add_argument("--motor", action="append", choices=sorted(MOTORS),
                        help="only these motors (repeatable)")
    parser.add_argument("--source", action="append", default=[],
                        help="run only these plans (repeatable; hil run --source)")
    parser.add_argument("--base-json", type=Path,
                        help="with --source: a full study's validity.json whose rows keep their "
                             "other plans' tests; only the re-run plans' tests are replaced")
    parser.add_argument("--dask", action="store_true",
                        help="run the points as a regression grid on Dask (an embedded "
                             "LocalCluster; resumable in OUT/grid)")
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help="with --dask: tcp://HOST:8786 of an existing Dask cluster")
    parser.add_argument("--workers", type=int, help="with --dask: LocalCluster workers")
    parser.add_argument("--point", action="append", default=[], metavar="RPM,A",
                        help="only these operating points of the chosen motors (repeatable), "
                             "e.g. --point=-400,12")
    parser.add_argument("--shuffle", type=int, metavar="SEED",
                        help="run the plans in a random order drawn with SEED (the self-check "
                             "first); the order is kept in each row")
    parser.add_argument("--deviation", action="append", default=[],
                        choices=[*sorted(DEVIATIONS), "all"],
                        help="run on a motor, loop and transducer off the nameplate (issue 29; "
                             "repeatable; 'all': every set) at the deviation points of the "
                             "deviation motors (or --motor/--point)")
    parser.add_argument("--from-json", type=Path,
                        help="only write the table again from a study's validity.json")
    args = parser.parse_args(argv)
    if args.from_json:
        rows = json.loads(args.from_json.read_text())["rows"]
        print(markdown(rows))
        return 1 if any(counts(row)[WRONG] for row in rows) else 0
    if args.reduced:
        plan = REDUCED
    else:
        plan = [(name, point) for name in (args.motor or MOTORS) for point in grid(name)]
    if args.point:
        points = [tuple(float(v) for v in text.split(",")) for text in args.point]
        plan = [(name, point) for name in (args.motor or MOTORS) for point in points]
    if args.deviation:
        chosen = sorted(DEVIATIONS) if "all" in args.deviation else args.deviation
        motors = args.motor or DEVIATION_MOTORS
        points = ([tuple(float(v) for v in text.split(",")) for text in args.point]
                  if args.point else None)
        plan = [(name, point, deviation) for deviation in chosen for name in motors
                for point in (points or deviation_grid(name))]
    sources = args.source
    if args.shuffle is not None:
        sources = plan_order(args.shuffle, args.source)
    args.out.mkdir(parents=True, exist_ok=True)
    rows = []
    if args.dask or args.scheduler:
        rows = run_on_dask(plan, sources, args.out / "grid", args.scheduler, args.workers)
        if args.base_json:
            rows = [with_base(row, args.base_json, set(args.source)) for row in rows]
        (args.out / "validity.json").write_text(json.dumps({"motors": MOTORS, "deviations": DEVIATIONS, "rows": rows},
                                                           indent=1))
    else:
        rows = _run_in_turn(plan, args, sources)
    table = markdown(rows)
    (args.out / "validity.md").write_text(table + "\n")
    print(table)
    return 1 if any(counts(row)[WRONG] for row in rows) else 0


def _run_in_turn(plan, args, sources) -> list[dict]:
    """The points one after another in this process's children (no Dask)."""
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for index, (name, (speed, current), deviation) in enumerate(_entries(plan)):
            row = run_point(name, speed, current, Path(tmp) / f"p{index}",
                            sources=sources, deviation=deviation)
            if args.shuffle is not None:
                row["plan_order"] = {"seed": args.shuffle, "plans": list(sources)}
            if args.base_json:
                row = with_base(row, args.base_json, set(args.source))
            rows.append(row)
            c = counts(row)
            print(f"{name} {speed:g} rpm {current:g} A {deviation or ''}: {dict(c)} ({row['seconds']} s)",
                  file=sys.stderr, flush=True)
            (args.out / "validity.json").write_text(json.dumps(
                {"motors": MOTORS, "deviations": DEVIATIONS, "rows": rows}, indent=1))
    return rows


if __name__ == "__main__":
    sys.exit(main())
