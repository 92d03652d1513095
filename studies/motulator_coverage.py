"""Study: does ``hil diagnose`` hold on a drive nobody here modelled? Coverage of its estimates on
captures of an independent simulator, motulator 0.18 (issue 23 item 6).

Run (after ``.ci/setup-motulator``)::

    PYTHONPATH=. .venv/bin/python studies/motulator_coverage.py [--drives 30] [--seed 0]
        [--additions] [--pwm-model carrier|zoh] [--jobs 2] [--no-replay]

Each drive (``studies/independent/run.py:random_drive``) gets random hidden faults — sensor
offsets ±0.3 A, gains ±2 %, dead time 0–2 µs (none on a quarter of the drives) — one of two
motors (Table I; 8-pole 48 V), motulator's own current controller (continuous 2-DOF or direct
discrete design, bandwidth 500–3000 Hz), 20 kHz SVPWM, and three captures (two speeds at one
current, one at another; 30 % of the drives in reverse rotation). motulator simulates them in
its own venv (``studies/independent/motulator_captures.py``); ``hil diagnose --manifest
DIR/manifest.toml --json`` diagnoses them; each identifiable estimate is compared with the truth:

* **covered**: |estimate − truth| ≤ U (the diagnosis' expanded uncertainty, k = 2);
* **confident wrong**: |estimate − truth| > 3·U while U is *small*, i.e. U < 25 % of the range
  the hidden parameter is drawn from (offsets 0.6 A → 0.15 A; k_a − k_b ≈ 8 % → 2 %; dead time
  2 µs → 0.5 µs): a tight interval that excludes the truth by far;
* **not identifiable**: the diagnosis declined to state the parameter.

Truth in the diagnosis' terms (``hil.diagnosis.twin_proof.HiddenFaults.expected``): the offsets
referred to the actual current, Δ/(1 + g); k_a − k_b with the paper's 1 + k = 1/(1 + g); T_d.

Also replayed: issue 23's three table rows (fixed drive: Δa +0.30 A, Δb −0.10 A, g_a +1.5 %,
1 kHz continuous loop; 500 + 1000 rpm at 20 A + 1000 rpm at 10 A without and with 1 µs dead
time; one capture at 500 rpm with 1 µs) and the capture as exported with and without its angle
reference stated (stated → the offsets' signs right; not stated → no signed calibration).

Bridge until helper diagin's ``--manifest`` lands: when ``hil diagnose --help`` has no
``--manifest``, :func:`diagnose_manifest` reads the manifest itself, imports each CSV with
``hil.capture_import``, rotates the capture's electrical angle by −emf_a_rising_zero_elec_deg (what
the manifest path will do) when it is stated, and calls ``hil.diagnosis.diagnose`` with the
manifest's loop — the same fit, so the figures carry over. Results: printed and written to
``studies/results/motulator_coverage.md``.
"""

from __future__ import annotations

import argparse
import functools
import json
import math
import subprocess
import sys
import time
import tomllib
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
sys.path.insert(0, str(HERE))
from independent.run import generate, issue23_drive, random_drive, restate  # noqa: E402

RESULTS = HERE / "results" / "motulator_coverage.md"
PARAMETERS = ("ia_offset_a", "ib_offset_a", "gain_k_diff", "dead_time_us")
#: Range each hidden parameter is drawn from (its unit as the diagnosis states it): "small U"
#: is U < SMALL_U_SHARE × this.
DRAWN_RANGE = {"ia_offset_a": 0.6, "ib_offset_a": 0.6,
               "gain_k_diff": 2 * (1 / 0.98 - 1 / 1.02), "dead_time_us": 2.0}
SMALL_U_SHARE = 0.25


# ------------------------------------------------------------------------------ diagnosis
@functools.cache
def cli_has_manifest() -> bool:
    """Whether this tree's ``hil diagnose`` has ``--manifest`` (asked once per process: a
    subprocess of ~1 s, and the answer cannot change while the process runs)."""
    proc = subprocess.run([sys.executable, "-m", "hil", "diagnose", "--help"],
                          capture_output=True, text=True)
    return "--manifest" in proc.stdout


def diagnose_manifest(manifest: Path, *, use_cli: bool | None = None) -> dict:
    """The diagnosis (``Diagnosis.to_dict()``) of a manifest's captures."""
    if use_cli is None:
        use_cli = cli_has_manifest()
    if use_cli:
        proc = subprocess.run([sys.executable, "-m", "hil", "diagnose", "--manifest",
                               str(manifest), "--json"], capture_output=True, text=True)
        if proc.returncode != 0:
            raise RuntimeError(f"hil diagnose --manifest {manifest} failed "
                               f"({proc.returncode}): {proc.stderr[-2000:]}")
        return json.loads(proc.stdout)
    return _diagnose_bridge(manifest)


def _diagnose_bridge(manifest: Path) -> dict:
    from hil.capture_import import import_capture
    from hil.diagnosis import diagnose, spectra_from_captures
    from hil.diagnosis.bench_setup import setup_from_bench_dict

    from dataclasses import fields

    from hil.diagnosis.signatures import DriveSetup

    data = tomllib.loads(manifest.read_text())
    drive, motor = data.get("drive", {}), data.get("motor", {})
    added = [e["file"] for e in data["capture"] if any(k.startswith("addition_") for k in e)]
    if added:
        raise RuntimeError(f"captures with known additions ({', '.join(added)}) need `hil "
                           "diagnose --manifest` (helpers diagin + additions); this tree has none")
    pole_pairs = int(drive["pole_pairs"])
    reference = drive.get("emf_a_rising_zero_elec_deg")
    pairs = []
    for entry in data["capture"]:
        capture = import_capture(manifest.parent / entry["file"], time_col="time_s",
                                 torque_col=entry.get("torque_column", "torque_nm"),
                                 angle_col=entry["angle_column"],
                                 angle_kind=entry.get("angle_kind", "mech"),
                                 pole_pairs=pole_pairs)
        if reference is not None:
            channels = dict(capture.channels)
            channels["rotor_angle_mech_rad"] = (np.asarray(channels["rotor_angle_mech_rad"])
                                                - math.radians(reference) / pole_pairs)
            capture = type(capture)(channels=channels, meta=capture.meta)
        pairs.append((capture, {"current_a": entry["current_a"],
                                "current_angle_rad": math.radians(
                                    entry.get("current_angle_deg", 0.0)),
                                "label": entry["file"]}))
    # every [drive] key this tree's DriveSetup knows (the loop design keys once they exist)
    known = {f.name for f in fields(DriveSetup)}
    setup, class_pct = setup_from_bench_dict(
        {"motor": motor, "drive": drive},
        **{k: v for k, v in drive.items() if k in known})
    result = diagnose(spectra_from_captures(pairs, max_mech_order=128), setup=setup,
                      transducer_class_pct=class_pct)
    return json.loads(json.dumps(result.to_dict()))


# ------------------------------------------------------------------------------ checks
def expected(truth: dict) -> dict[str, float]:
    """Hidden values under the diagnosis' parameter names."""
    h = truth["hidden"]
    return {"ia_offset_a": h["ia_offset_a"] / (1 + h["ia_gain_error_pu"]),
            "ib_offset_a": h["ib_offset_a"] / (1 + h["ib_gain_error_pu"]),
            "gain_k_diff": 1 / (1 + h["ia_gain_error_pu"]) - 1 / (1 + h["ib_gain_error_pu"]),
            "dead_time_us": h["dead_time_s"] * 1e6}


#: The standard-additions result (hil.diagnosis.additions: ``estimates``) names the gain
#: θ_g = (1 + g_a)/(1 + g_b) − 1 and states the offsets as the sensors read them.
ADDITIONS_NAMES = {"gain_k_diff": "gain_a_rel_b_pu"}


def expected_by_additions(truth: dict) -> dict[str, float]:
    h = truth["hidden"]
    return {"ia_offset_a": h["ia_offset_a"], "ib_offset_a": h["ib_offset_a"],
            "gain_k_diff": (1 + h["ia_gain_error_pu"]) / (1 + h["ib_gain_error_pu"]) - 1,
            "dead_time_us": h["dead_time_s"] * 1e6}


def check(diagnosis: dict, truth: dict) -> list[dict]:
    """One row per parameter: covered / confident wrong / not identifiable (either result
    format: the fit's ``parameters`` or the standard additions' ``estimates``)."""
    if "parameters" not in diagnosis and "estimates" in diagnosis:
        hidden = expected_by_additions(truth)
        by_name = {name: None for name in PARAMETERS}
        for item in diagnosis["estimates"]:
            if item["name"] in ADDITIONS_NAMES:
                continue     # its first-order k_a − k_b ≈ −θ_g; θ_g itself is judged
            key = next((k for k, v in ADDITIONS_NAMES.items() if v == item["name"]),
                       item["name"])
            by_name[key] = dict(item, identifiable=bool(item.get("stated"))
                                and item.get("estimate") is not None)
        # what the additions do not state, hil diagnose states from the forward-model fit of
        # the base captures it prints beside them (in the fit's conventions)
        fit = {p["name"]: p for p in (diagnosis.get("fit") or {}).get("parameters", [])}
        for name in PARAMETERS:
            if not (by_name[name] or {}).get("identifiable") and fit.get(name, {}).get(
                    "identifiable"):
                by_name[name] = dict(fit[name], route="fit")
                hidden = dict(hidden, **{name: expected(truth)[name]})
    else:
        hidden = expected(truth)
        by_name = {p["name"]: p for p in diagnosis["parameters"]}
    rows = []
    for name in PARAMETERS:
        p = by_name.get(name)
        row = {"name": name, "hidden": hidden[name]}
        if p is None or not p.get("identifiable") or p.get("estimate") is None:
            row["identifiable"] = False
        elif p.get("sign_identifiable") is False:   # angle reference unknown: no signed value
            row |= {"identifiable": False, "sign_unknown": True}
        else:
            est, u = p["estimate"], p["expanded_uncertainty"]
            err = abs(est - hidden[name])
            row |= {"identifiable": True, "estimate": est, "U": u, "covered": err <= u,
                    "confident_wrong": err > 3 * u and u < SMALL_U_SHARE * DRAWN_RANGE[name]}
        rows.append(row)
    return rows


def table(cases: list[dict]) -> list[dict]:
    out = []
    for name in PARAMETERS:
        rows = [r for c in cases for r in c["checks"] if r["name"] == name]
        judged = [r for r in rows if r["identifiable"]]
        ratios = [abs(r["estimate"] - r["hidden"]) / r["U"] for r in judged if r["U"]]
        out.append({"name": name, "drives": len(rows), "judged": len(judged),
                    "covered": sum(r["covered"] for r in judged),
                    "not_identifiable": len(rows) - len(judged),
                    "confident_wrong": sum(r["confident_wrong"] for r in judged),
                    "mean_err_over_u": float(np.mean(ratios)) if ratios else float("nan")})
    return out


def run_drive(spec: dict, out_dir: Path, use_cli: bool | None, *,
              simulate: bool = True) -> dict:
    """Simulate ``spec`` into ``out_dir`` (unless ``simulate`` is False: captures already
    there), diagnose, check."""
    started = time.perf_counter()
    manifest = generate(spec, out_dir) if simulate else restate(out_dir)
    simulated = time.perf_counter() - started
    truth = json.loads((out_dir / "truth.json").read_text())
    try:
        diagnosis = diagnose_manifest(manifest, use_cli=use_cli)
    except Exception as exc:  # noqa: BLE001 - an error is a result of the study, reported
        return {"spec": spec, "dir": str(out_dir), "error": f"{type(exc).__name__}: {exc}",
                "checks": [{"name": n, "hidden": v, "identifiable": False}
                           for n, v in expected(truth).items()]}
    return {"spec": spec, "dir": str(out_dir), "checks": check(diagnosis, truth),
            "diagnosis": diagnosis, "truth": truth,
            "seconds": {"simulation": simulated, "total": time.perf_counter() - started}}


def with_additions(spec: dict) -> dict:
    """The drive plus standard additions (issue 23 item 1, shared23.md keys), as the diagnosis
    plan designs them (testplans/diagnosis_design.py on the additions branch) but at this
    drive's own points: at its fast high-current point (the second) +0.2/+0.4 A on each sensor,
    +1/+2 % gain on sensor a, +0.5/+1 µs dead time; at its low-current point (the third) +1 %
    gain on a. Two sizes each: the linearity check."""
    fast, low = spec["points"][1], spec["points"][2]
    extra = [dict(fast, **{key: value}) for key, value in (
        ("addition_ia_offset_a", 0.2), ("addition_ia_offset_a", 0.4),
        ("addition_ib_offset_a", 0.2), ("addition_ib_offset_a", 0.4),
        ("addition_gain_a_pu", 0.01), ("addition_gain_a_pu", 0.02),
        ("addition_dead_time_s", 0.5e-6), ("addition_dead_time_s", 1e-6))]
    extra.append(dict(low, addition_gain_a_pu=0.01))
    return dict(spec, points=list(spec["points"]) + extra)


# ------------------------------------------------------------------------------ replay
def replay_rows(work: Path, use_cli: bool | None, pwm_model: str, *,
                simulate: bool = True) -> list[dict]:
    """Issue 23's table rows and the angle-reference cases on its fixed drive."""
    if not simulate and not (work / "replay2" / "truth.json").is_file():
        return []                                     # that run has no (finished) replay
    three = [(500.0, 20.0), (1000.0, 20.0), (1000.0, 10.0)]
    cases = [("500 + 1000 rpm at 20 A, + 1000 rpm at 10 A", issue23_drive(
                 dead_time_s=0.0, points=three, pwm_model=pwm_model)),
             ("same with 1 µs dead time", issue23_drive(
                 dead_time_s=1e-6, points=three, pwm_model=pwm_model)),
             ("one capture, 500 rpm, 1 µs", issue23_drive(
                 dead_time_s=1e-6, points=[(500.0, 20.0)], pwm_model=pwm_model))]
    out = []
    for index, (title, spec) in enumerate(cases):
        result = run_drive(spec, work / f"replay{index}", use_cli, simulate=simulate)
        result["title"] = title
        out.append(result)
    # the capture as exported (torque + angle): same captures as row 1, with and without the
    # reference; and not stated but with the phase currents (the diagnosis may measure it)
    source = work / "replay0"
    truth = json.loads((source / "truth.json").read_text())
    for title, reference, currents in (
            ("as exported, angle reference stated", True, False),
            ("as exported, angle reference NOT stated", False, False),
            ("reference NOT stated, phase currents in the CSV", False, True)):
        folder = export_copy(source, work / f"replay0_{'stated' if reference else 'unstated'}"
                             f"{'_currents' if currents else ''}", reference=reference,
                             currents=currents)
        try:
            diagnosis = diagnose_manifest(folder, use_cli=use_cli)
        except Exception as exc:  # noqa: BLE001
            out.append({"title": title, "error": f"{type(exc).__name__}: {exc}", "checks": []})
            continue
        out.append({"title": title, "checks": check(diagnosis, truth), "diagnosis": diagnosis,
                    "truth": truth, "angle_case": True, "reference_stated": reference})
    return out


def export_copy(source: Path, target: Path, *, reference: bool, currents: bool) -> Path:
    """A copy of a capture folder as another bench would export it: the manifest with or
    without its ``emf_a_rising_zero_elec_deg`` line, the CSVs with or without the phase-current
    columns (torque and angle only). Returns the copy's manifest."""
    target.mkdir(parents=True, exist_ok=True)
    for path in source.iterdir():
        text = path.read_text()
        if path.name == "manifest.toml" and not reference:
            text = "\n".join(line for line in text.splitlines()
                             if not line.startswith("emf_a_rising_zero_elec_deg")) + "\n"
        elif path.suffix == ".csv" and not currents:
            rows = [line.split(",") for line in text.splitlines()]
            keep = [i for i, name in enumerate(rows[0]) if name not in ("ia_a", "ib_a", "ic_a")]
            text = "\n".join(",".join(row[i] for i in keep) for row in rows) + "\n"
        (target / path.name).write_text(text)
    return target / "manifest.toml"


def signed_calibration(diagnosis: dict) -> dict:
    cal = diagnosis.get("calibration") or {}
    return {k: (None if cal.get(k) is None else cal[k]["value"])
            for k in ("ia_offset_correction_a", "ib_offset_correction_a")}


# ------------------------------------------------------------------------------ report
def _cell(row: dict, scale: float = 1.0, unit: str = "") -> str:
    if not row["identifiable"]:
        return "sign not identifiable" if row.get("sign_unknown") else "not identifiable"
    mark = "✔" if row["covered"] else ("✘ confident wrong" if row["confident_wrong"] else "✘")
    return (f"{row['estimate'] * scale:+.4g} ± {row['U'] * scale:.2g}{unit} {mark} "
            f"(truth {row['hidden'] * scale:+.4g})")


def _not_separable(diagnosis: dict) -> str:
    weak = (diagnosis.get("identifiability") or {}).get("weak_combinations") or []
    return "; ".join(", ".join(w["parameters"]) for w in weak) or "—"


def report(args, cases, replay, wall, use_cli) -> str:
    lines = [f"# Diagnosis coverage on an independent simulator (motulator 0.18)", "",
             f"Run {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}: `PYTHONPATH=. "
             f".venv/bin/python studies/motulator_coverage.py --drives {args.drives} "
             f"--seed {args.seed} --pwm-model {args.pwm_model}"
             f"{' --additions' if args.additions else ''}"
             f"{' --captures-from ' + args.captures_from if args.captures_from else ''}` "
             f"({wall:.0f} s wall). Diagnosis "
             f"through {'`hil diagnose --manifest --json`' if use_cli else 'the bridge (no `--manifest` in this tree yet: manifest read by the study, angle rotated by the stated reference, `hil.diagnosis.diagnose` with the manifest loop)'}.",
             "", "covered: |est − truth| ≤ U (k = 2); confident wrong: |est − truth| > 3U with "
             f"U < {SMALL_U_SHARE:.0%} of the drawn range (offsets 0.15 A, k_a − k_b 2 %, dead "
             "time 0.5 µs).", "",
             "| parameter | drives | judged | covered | coverage | mean abs(err)/U | not identifiable | confident wrong |",
             "|---|---|---|---|---|---|---|---|"]
    for row in table(cases):
        share = f"{100 * row['covered'] / row['judged']:.0f} %" if row["judged"] else "—"
        lines.append(f"| {row['name']} | {row['drives']} | {row['judged']} | {row['covered']} | "
                     f"{share} | {row['mean_err_over_u']:.2f} | {row['not_identifiable']} | "
                     f"{row['confident_wrong']} |")
    errors = [c for c in cases if "error" in c]
    lines += ["", f"Errors: {len(errors)}" + "".join(f"\n- {c['dir']}: {c['error'][:300]}"
                                                     for c in errors)]
    lines += ["", "Misses (identifiable, not covered):"]
    for i, case in enumerate(cases):
        for r in case["checks"]:
            if r["identifiable"] and not r["covered"]:
                s = case["spec"]
                lines.append(f"- drive {i} ({s['motor']['name']}, {s['loop']['design']} "
                             f"{s['loop']['bandwidth_hz']:.0f} Hz, T_d "
                             f"{s['faults']['dead_time_s'] * 1e6:.2f} µs): {r['name']} "
                             f"{r['estimate']:+.5g} ± {r['U']:.2g}, truth {r['hidden']:+.5g}"
                             + (" — CONFIDENT WRONG" if r["confident_wrong"] else ""))
    if replay:
        lines += ["", "## Issue 23's rows replayed", "",
                  "| captures | Δa | Δb | k_a − k_b | T_d | not separable |", "|---|---|---|---|---|---|"]
        for case in replay:
            if "error" in case:
                lines.append(f"| {case['title']} | error: {case['error'][:200]} |||||")
                continue
            c = {r["name"]: r for r in case["checks"]}
            lines.append(f"| {case['title']} | {_cell(c['ia_offset_a'])} | "
                         f"{_cell(c['ib_offset_a'])} | {_cell(c['gain_k_diff'], 100, ' %')} | "
                         f"{_cell(c['dead_time_us'], 1, ' µs')} | "
                         f"{_not_separable(case['diagnosis'])} |")
        lines += [""]
        for case in replay:
            if case.get("angle_case") and "diagnosis" in case:
                cal = signed_calibration(case["diagnosis"])
                lines.append(f"- {case['title']}: calibration printed: sensor a "
                             f"{cal['ia_offset_correction_a']}, sensor b "
                             f"{cal['ib_offset_correction_a']} (truth: correct a by −0.30 A, b "
                             f"by +0.10 A)")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--drives", type=int, default=30)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--additions", action="store_true",
                        help="also simulate the standard additions at each drive's first point")
    parser.add_argument("--pwm-model", choices=("carrier", "zoh"), default="carrier",
                        help="motulator's carrier comparison (default) or its averaged ZOH model")
    parser.add_argument("--mech-revolutions", type=int, default=3)
    parser.add_argument("--jobs", type=int, default=2, help="drives simulated at once")
    parser.add_argument("--no-replay", action="store_true")
    parser.add_argument("--start", type=int, default=0, metavar="K",
                        help="simulate only drives K.. of the seed's sequence (to share a run "
                             "between processes; join them with --captures-from)")
    parser.add_argument("--work", default=None, help="folder for the captures (default: a "
                        "temporary folder under /tmp)")
    parser.add_argument("--write", default=str(RESULTS), help="markdown result file ('' = none)")
    parser.add_argument("--captures-from", default=None, metavar="WORK",
                        help="diagnose the captures a previous run left in WORK again (no "
                             "simulation; e.g. after the diagnosis changed)")
    parser.add_argument("--reuse-base", default=None, metavar="WORK",
                        help="with --additions: copy each drive's base captures from a run "
                             "without additions in WORK (same seed) and simulate only the "
                             "additions (motulator is deterministic: the same spec gives the "
                             "same capture)")
    args = parser.parse_args(argv)
    import shutil
    import tempfile
    simulate = args.captures_from is None
    work = Path(args.captures_from or args.work or tempfile.mkdtemp(prefix="motulator-coverage-"))
    use_cli = cli_has_manifest()
    rng = np.random.default_rng(args.seed)
    specs = [random_drive(rng, mech_revolutions=args.mech_revolutions,
                          pwm_model=args.pwm_model) for _ in range(args.drives)]
    if args.additions:
        specs = [with_additions(s) for s in specs]
        if args.reuse_base:
            for index, spec in enumerate(specs):
                spec["reuse_existing"] = True
                base, target = Path(args.reuse_base) / f"drive{index:03d}", work / f"drive{index:03d}"
                target.mkdir(parents=True, exist_ok=True)
                for csv in base.glob("*.csv"):
                    shutil.copy(csv, target / csv.name)
    folders = []
    if not simulate:
        folders = sorted(f for f in work.glob("drive[0-9][0-9][0-9]")
                         if (f / "truth.json").is_file())     # finished drives only
        specs = [json.loads((f / "truth.json").read_text())["spec"] for f in folders]
        args.drives = len(specs)
    started = time.perf_counter()
    with ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        if simulate:
            targets = [work / f"drive{i:03d}" for i in range(args.start, len(specs))]
            specs = specs[args.start:]
        else:
            targets = folders
        cases = list(pool.map(lambda item: run_drive(item[1], item[0], use_cli,
                                                     simulate=simulate),
                              zip(targets, specs)))
    replay = [] if args.no_replay else replay_rows(work, use_cli, args.pwm_model,
                                                   simulate=simulate)
    wall = time.perf_counter() - started
    text = report(args, cases, replay, wall, use_cli)
    print(text)
    print(f"(captures in {work})")
    if args.write:
        Path(args.write).parent.mkdir(parents=True, exist_ok=True)
        Path(args.write).write_text(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
