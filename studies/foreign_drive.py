"""The plans against a drive nobody here wrote (issue 30 item 3): motulator's PMSM, inverter and
current controller behind the simulated instruments (``[simulation] plant = "motulator"``,
``hil/examples/foreign.toml``), every run as a user runs it: ``hil run --bench COPY`` under
``.venv-motulator/bin/python``, the bench file stating the drive's nameplate and documented loop.

Two parts, in priority order:

1. **Correct drive**: per motor (Table I; the validity study's 8-pole 48 V motor) and operating
   point (both directions, low and high current, near the voltage limit), one run of the plans
   in :data:`PLANS` (one injection level each: motulator runs at ≈ 100 CPU s per simulated
   second, so the full plan set per point is out of reach), each test classified as in
   ``studies/validity.py`` (pass / wrong rejection / not determinable with the reason /
   measured / error).
2. **Defects** (:data:`DEFECTS`): the same drive made wrong the ways the plans exist to catch
   (``--sim-defect``, ``hil.sim.defects`` applied to the commanded injection before motulator
   runs it), each at one point with the plan that must catch it: ``caught`` when that plan
   fails, ``MISSED`` when it passes.

Run: ``.venv/bin/python studies/foreign_drive.py [--part correct|defects] [--motor NAME]
[--only LABEL] [--out DIR]`` (each run is a subprocess of ``.venv-motulator/bin/python -m hil
run``); ``--from-json FILE`` prints the table again. Writes ``DIR/foreign_drive.json`` (appended
run by run, so an interrupted study keeps what it measured) and ``DIR/foreign_drive.md``.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
import tomllib
from pathlib import Path

import tomli_w

sys.path.insert(0, str(Path(__file__).resolve().parent))
from validity import (ERROR, MEASURED, NOT_DET, PASS, WRONG, MOTORS,  # noqa: E402
                      classify, motor_parameters, near_limit_speed_rpm)

REPO = Path(__file__).resolve().parents[1]
FOREIGN_BENCH = REPO / "hil" / "examples" / "foreign.toml"
VENV_PYTHON = REPO / ".venv-motulator" / "bin" / "python"
RUN_TIMEOUT_S = 7200.0

#: plan -> pytest -k expression selecting its one test (injection level) run at every point
PLANS = {
    "self_check": "test_bench_self_check or test_angle_reference",
    "dc_offset": "test_dc_offset[0.01-0.0]",
    "gain_mismatch": "(test_gain_mismatch and -0.02])",
    "dead_time": "(test_dead_time and 3e-06])",
    "pwm_resolution": "(test_pwm_resolution and 64])",
    "word_length": "(test_word_length and 12])",
    # added 2026-12-08 (run at every point with --plan): 20 kHz is the drive's own carrier.
    # The encoder is not run at every point: its 12 rpm capture costs ≈ 30 min of motulator
    # (``--part encoder`` runs it at one point)
    "pwm_switching": "(test_pwm_switching and 20000)",
    "baseline": "test_baseline",
}
#: the correct drive's points per motor (speed rpm, peak current A); "near" = the motor's
#: near-voltage-limit speed at 20 A (``studies/validity.near_limit_speed_rpm``)
POINTS = {
    "table_i": [(1000.0, 20.0), (-1000.0, 20.0), (1000.0, 5.0), (1000.0, 30.0), ("near", 20.0),
                ("-near", 20.0)],
    "p8_48v": [(800.0, 15.0), (-800.0, 15.0), (800.0, 5.0), ("near", 20.0), ("-near", 20.0),
               (-800.0, 5.0)],
}
#: defect label -> (plan that must catch it, --sim-defect values, point (motor, rpm, A)); each
#: run starts with the self-check's angle reference, as a user's run of all plans does
DEFECTS = {
    "offset ignored": ("dc_offset", {"ignore_injection": "ia_offset_a,ib_offset_a"},
                       ("table_i", 1000.0, 20.0)),
    "offset mis-scaled x1.5": ("dc_offset", {"injection_scale": 1.5}, ("table_i", 1000.0, 20.0)),
    "gain applied inversely": ("gain_mismatch", {"gain_applied_inverse": True},
                               ("table_i", 1000.0, 20.0)),
    # 1000 rpm / 20 A with 3 us is outside the voltage headroom (not determinable): 800 rpm
    "dead time 1.5x commanded": ("dead_time", {"injection_scale": 1.5}, ("table_i", 800.0, 20.0)),
    "encoder decimation ignored": ("encoder", {"ignore_injection": "encoder_decimation"},
                                   ("table_i", 1000.0, 20.0)),
    "transducer reads 5 % high": ("self_check", {"transducer_scale": 1.05},
                                  ("table_i", 1000.0, 20.0)),
    # the 10 kHz point (20 kHz is the default, which injection_scale leaves alone): the drive
    # switches at 5 kHz, twice the ripple
    "PWM frequency applied at half": ("pwm_switching", {"injection_scale": 0.5},
                                      ("table_i", 1000.0, 20.0)),
}
#: selectors of plans run only for a defect
DEFECT_SELECTORS = {"encoder": "(test_encoder_resolution and 50])",
                    "self_check": "test_bench_self_check",
                    "pwm_switching": "(test_pwm_switching and 10000)"}
ANGLE_REFERENCE = "test_angle_reference"
CAUGHT, MISSED = "caught", "MISSED"
#: a stored test marked ``"superseded": "<why>"`` (after the fact): judged against a model of a
#: loop the bench file misstated (it could not state motulator's 2-DOF design before
#: ``current_loop_design = "2dof"``); its re-run with the loop stated is in another row
SUPERSEDED = "superseded (loop misstated)"
#: a stored test marked ``"void": "<why>"`` (after the fact, with the reason): it ran on a plant
#: with a fault of ours, so it is no statement about the plan
VOID = "void (plant fault)"


def speed_of(motor: str, speed) -> float:
    if isinstance(speed, str):
        limit = tomllib.loads(FOREIGN_BENCH.read_text())["limits"]["speed_rpm"]
        near = near_limit_speed_rpm(motor_parameters(motor), limit)
        return -near if speed.startswith("-") else near
    return float(speed)


def bench_copy(motor: str, speed_rpm: float, current_a: float, folder: Path) -> Path:
    """``foreign.toml`` with this motor's nameplate and operating point."""
    table = tomllib.loads(FOREIGN_BENCH.read_text())
    table["motor"] = table["motor"] | MOTORS[motor]
    table["operating_point"] = {"speed_rpm": speed_rpm, "current_a": current_a,
                                "current_angle_deg": 0.0}
    path = folder / f"foreign-{motor}-{speed_rpm:g}rpm-{current_a:g}A.toml"
    path.write_text(tomli_w.dumps(table))
    return path


def hil_run(bench: Path, sources: dict, folder: Path, defects: dict | None = None) -> dict:
    """One ``hil run`` under ``.venv-motulator``: the named tests of the named plans."""
    records = folder / "records"
    args = [str(VENV_PYTHON), "-m", "hil", "run", "--bench", str(bench), "--no-report",
            "--record-dir", str(records), "--results-db", "off"]
    for source in sources:
        args += ["--source", source]
    for key, value in (defects or {}).items():
        value = ("true" if value else "false") if isinstance(value, bool) else value
        args += ["--sim-defect", f"{key}={value}"]
    args += ["--", "-k", " or ".join(sources.values())]
    started = time.perf_counter()
    done = subprocess.run(args, capture_output=True, text=True, timeout=RUN_TIMEOUT_S,
                          cwd=folder)
    row = {"wall_s": round(time.perf_counter() - started, 1), "exit": done.returncode,
           "command": " ".join(args[1:])}
    found = sorted(records.glob("*/record.json")) if records.exists() else []
    if not found:
        row["error"] = (done.stderr or done.stdout)[-2000:]
        return row | {"tests": []}
    return record_row(found[-1].parent, row)


def record_row(record_dir: Path, row: dict) -> dict:
    """``row`` (how the run was made) with the plant, the drive's identity and each test's
    category from the record in ``record_dir`` (also for a ``hil run`` made by hand)."""
    from hil.record import load_record

    record = load_record(record_dir)
    row["plant"] = record["bench"]["loaded"].get("simulation", {}).get("plant", "ripple-hil")
    row["drive_firmware"] = next((i["identity"].get("firmware") for i in record["instruments"]
                                  if i["role"] == "drive"), None)
    row["tests"] = []
    for test in record["tests"]:
        category, reason = classify(test)
        row["tests"].append({"test": test["test_id"].split("::")[-1],
                             "source": test.get("source"), "category": category,
                             "reason": (reason or "")[:400]})
    return row


def run_correct(motor: str, point, out: Path, plans: list[str] | None = None) -> dict:
    """One run of ``plans`` (default all of :data:`PLANS`) at the point, the self-check's
    angle reference always with them (the order-phase verdicts need it)."""
    speed = speed_of(motor, point[0])
    chosen = {name: PLANS[name] for name in plans} if plans else PLANS
    if "self_check" not in chosen:
        chosen = {"self_check": ANGLE_REFERENCE} | chosen
    with tempfile.TemporaryDirectory(prefix="foreign-") as tmp:
        folder = Path(tmp)
        bench = bench_copy(motor, speed, point[1], folder)
        row = hil_run(bench, chosen, folder)
    return {"part": "correct", "motor": motor, "speed_rpm": speed, "current_a": point[1]} | row


def run_defect(label: str, out: Path, *, reference: bool = False) -> dict:
    """The defect's plan at its point with the defect; ``reference``: the same run of the
    correct drive (a "correct" row), so that "caught" is measured against a drive that passes
    the same test there."""
    plan, defects, (motor, speed, current) = DEFECTS[label]
    if reference:
        defects = {}
    selector = DEFECT_SELECTORS.get(plan, PLANS.get(plan))
    sources = {"self_check": ANGLE_REFERENCE} | {plan: selector}
    if plan == "self_check":
        sources = {plan: f"{selector} or {ANGLE_REFERENCE}"}
    with tempfile.TemporaryDirectory(prefix="foreign-") as tmp:
        folder = Path(tmp)
        bench = bench_copy(motor, speed, current, folder)
        row = hil_run(bench, sources, folder, defects)
    if reference:
        return {"part": "correct", "motor": motor, "speed_rpm": speed, "current_a": current,
                "reference_for": label} | row
    row = {"part": "defect", "defect": label, "plan": plan, "defects": defects,
           "motor": motor, "speed_rpm": speed, "current_a": current} | row
    return row | {"outcome": defect_outcome(row)}


def run_dead_time_after_fix(out: Path) -> dict:
    """The correct drive's dead-time point alone (with the angle reference), at the point where
    it was wrongly rejected while the plant did not apply the dead time."""
    with tempfile.TemporaryDirectory(prefix="foreign-") as tmp:
        folder = Path(tmp)
        bench = bench_copy("p8_48v", -800.0, 15.0, folder)
        row = hil_run(bench, {"self_check": ANGLE_REFERENCE, "dead_time": PLANS["dead_time"]},
                      folder)
    return {"part": "correct", "motor": "p8_48v", "speed_rpm": -800.0, "current_a": 15.0} | row


def run_encoder_correct(out: Path) -> dict:
    """The correct drive's encoder point (decimation 50, the plan's own 12 rpm): the reference
    against which the "encoder decimation ignored" defect means something."""
    with tempfile.TemporaryDirectory(prefix="foreign-") as tmp:
        folder = Path(tmp)
        bench = bench_copy("table_i", 1000.0, 20.0, folder)
        row = hil_run(bench, {"self_check": ANGLE_REFERENCE,
                              "encoder": DEFECT_SELECTORS["encoder"]}, folder)
    return {"part": "correct", "motor": "table_i", "speed_rpm": 1000.0, "current_a": 20.0} | row


def run_control(out: Path) -> dict:
    """The correct drive, the offset plan alone (no self-check, the bench file stating no angle
    reference): what the order-1 phase verdict does without an angle reference."""
    with tempfile.TemporaryDirectory(prefix="foreign-") as tmp:
        folder = Path(tmp)
        bench = bench_copy("table_i", 1000.0, 20.0, folder)
        row = hil_run(bench, {"dc_offset": PLANS["dc_offset"]}, folder)
    return {"part": "control", "motor": "table_i", "speed_rpm": 1000.0, "current_a": 20.0} | row


def verdict_of(test: dict) -> str:
    """The stored category, a failure that is not a verdict (an instrument timeout, a crash: its
    reason is not an ``AssertionError``) counted as an error, never as a rejection."""
    if test.get("void"):
        return VOID
    if test.get("superseded"):
        return SUPERSEDED
    if test["category"] == WRONG and not test["reason"].startswith("AssertionError"):
        return ERROR
    return test["category"]


def defect_outcome(row: dict) -> str:
    judged = [verdict_of(t) for t in row["tests"] if t["source"] == row["plan"]
              and t["test"] != ANGLE_REFERENCE]
    if WRONG in judged:
        return CAUGHT
    if judged and all(c == PASS for c in judged):
        return MISSED
    return judged[0] if judged else ERROR


def table(rows: list[dict]) -> str:
    lines = ["## Correct foreign drive", "",
             "| motor | point | test | result | reason |", "|---|---|---|---|---|"]
    judged = wrong = model_points = model_judged = replaced = 0
    for row in (r for r in rows if r["part"] == "correct"):
        point = f"{row['speed_rpm']:+g} rpm, {row['current_a']:g} A"
        if not row["tests"]:
            lines.append(f"| {row['motor']} | {point} | (run) | error | "
                         f"{row.get('error', '')[-200:]!r} |")
        for t in row["tests"]:
            reason = t["reason"].replace("|", "/").replace("\n", " ")
            category = verdict_of(t)
            reason = t.get("void") or t.get("superseded") or reason
            lines.append(f"| {row['motor']} | {point} | {t['test']} | {category} | "
                         f"{reason} |")
            if category in (SUPERSEDED, VOID):    # each run again in a row of its own
                replaced += 1
                continue
            if t["source"] not in ("self_check",):
                model_points += 1
                model_judged += category in (PASS, WRONG)
            judged += category in (PASS, WRONG)
            wrong += category == WRONG
    lines += ["", f"Judged {judged}, wrong rejections {wrong}; model-validation tests judged "
              f"{model_judged}/{model_points}"
              + (f" ({100 * model_judged / model_points:.0f} %)" if model_points else "")
              + (f"; {replaced} superseded or void rows (run again, counted in their re-runs' "
                 "rows) left out" if replaced else ""), "",
              "## Defects of the foreign drive", "",
              "| defect | --sim-defect | plan | result | reason |", "|---|---|---|---|---|"]
    for row in (r for r in rows if r["part"] == "defect"):
        reason = next((t["reason"] for t in row["tests"] if t["source"] == row["plan"]),
                      row.get("error", ""))
        reason = (reason or "").replace("|", "/").replace("\n", " ")[:400]
        lines.append(f"| {row['defect']} | {row['defects']} | {row['plan']} | {defect_outcome(row)} "
                     f"| {reason} |")
    controls = [r for r in rows if r["part"] == "control"]
    if controls:
        lines += ["", "## Control: the offset plan alone, no angle reference stated or measured",
                  "", "| point | test | result | reason |", "|---|---|---|---|"]
        for row in controls:
            for t in row["tests"]:
                reason = t["reason"].replace("|", "/").replace("\n", " ")[:300]
                lines.append(f"| {row['speed_rpm']:+g} rpm, {row['current_a']:g} A | {t['test']} "
                             f"| {verdict_of(t)} | {reason} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--part", choices=("correct", "defects", "defect-references",
                                           "control", "dead-time", "encoder", "all"),
                        default="all")
    parser.add_argument("--motor", action="append", choices=sorted(POINTS))
    parser.add_argument("--plan", action="append", choices=sorted(PLANS),
                        help="with --part correct: run only these plans (and the angle "
                             "reference) at each point")
    parser.add_argument("--only", action="append", default=[],
                        help="a defect label, or a point as MOTOR:SPEED:CURRENT")
    parser.add_argument("--out", default="studies/results/foreign")
    parser.add_argument("--from-json", nargs="+", metavar="FILE",
                        help="print the table of these stored runs (merged) and exit")
    args = parser.parse_args(argv)
    if args.from_json:
        print(table([row for name in args.from_json
                     for row in json.loads(Path(name).read_text())["rows"]]))
        return 0
    if not VENV_PYTHON.is_file():
        print(f"{VENV_PYTHON} missing: run .ci/setup-motulator", file=sys.stderr)
        return 2
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    store = out / "foreign_drive.json"
    rows = json.loads(store.read_text())["rows"] if store.exists() else []
    jobs = []
    if args.part in ("correct", "all"):
        for motor in args.motor or POINTS:
            for point in POINTS[motor]:
                label = f"{motor}:{point[0]}:{point[1]:g}"
                if not args.only or label in args.only:
                    jobs.append(("correct", motor, point))
    if args.part in ("defects", "all"):
        jobs += [("defect", label, None) for label in DEFECTS
                 if not args.only or label in args.only]
    if args.part == "defect-references":
        jobs = [("reference", label, None) for label in DEFECTS
                if not args.only or label in args.only]
    if args.part == "control":
        jobs = [("control", None, None)]
    if args.part == "dead-time":
        jobs = [("dead-time", None, None)]
    if args.part == "encoder":
        jobs = [("encoder", None, None)]
    for kind, what, point in jobs:
        row = (run_correct(what, point, out, args.plan) if kind == "correct" else
               run_defect(what, out) if kind == "defect" else
               run_defect(what, out, reference=True) if kind == "reference" else
               run_dead_time_after_fix(out) if kind == "dead-time" else
               run_encoder_correct(out) if kind == "encoder" else run_control(out))
        rows.append(row)
        store.write_text(json.dumps({"rows": rows}, indent=1))
        print(json.dumps({k: v for k, v in row.items() if k != "tests"}), flush=True)
    (out / "foreign_drive.md").write_text(table(rows))
    print(table(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
