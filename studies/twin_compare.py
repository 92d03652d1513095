"""Study: the user's own twin against its bench, every plan (issue 29 "Done when").

Run: ``.venv/bin/python studies/twin_compare.py [--source NAME …] [--workdir DIR] [--no-write]``
(writes ``studies/results/twin_compare.md``; ``--source`` narrows every run to those plans).

Every step is a ``hil`` command in its own process, as a user types it, in ``DIR`` (a temporary
folder by default); the runs are indexed into ``DIR/records/results.sqlite``. Cases:

- **deviated bench**: ``hil/examples/sim-bench.toml`` with ``[simulation.actual]`` R × 1.3,
  L × 0.8, Ke × 0.96 of its ``[motor]`` and loop bandwidth × 0.9 (``DEVIATION``):
  ``hil characterize --write-twin``, ``hil run`` of the bench (seed 0) and of the twin (seed 1),
  ``hil compare TWIN BENCH`` (d = bench − twin);
- **extra hidden fault**: the same bench with ``[simulation.defects] hidden_ia_offset_a = 0.3``
  added after the twin was written (seed 2), against the same twin;
- **the bench twice**: the deviated bench at seed 3 against seed 0 (what the compare finds
  between two runs of one bench);
- **saturating and warming bench** (what the twin does not carry over): the deviated bench
  whose L saturates (i_sat = 40 A: L(20 A) = 0.8·L, the unsaturated L the nameplate's) and whose
  winding warms (τ 60 s, +20 % at 20 A), its own twin, seeds 0 and 1.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time
import tomllib
from pathlib import Path

from hil.config import example_bench_path

RESULT = Path(__file__).parent / "results" / "twin_compare.md"
#: The deviated bench's hidden physics, as multiples of its file's [motor] and [drive] values.
DEVIATION = {"phase_resistance_ohm": 1.3, "phase_inductance_h": 0.8, "ke_v_s_per_rad": 0.96,
             "current_loop_bandwidth_hz": 0.9}
#: The extra hidden fault: a 0.3 A offset on phase a's current sensor (hil/sim/defects.py).
FAULT = {"hidden_ia_offset_a": 0.3}
#: Saturation and warming on top of DEVIATION (the unsaturated L is then the nameplate's).
SATURATING_WARMING = {"phase_inductance_h": 1.0, "saturation_current_a": 40.0,
                      "winding_time_constant_s": 60.0, "winding_rise_pu_per_a2": 0.2 / 20.0 ** 2}


def deviated_bench(path: Path, *, defects: dict | None = None,
                   actual_factors: dict | None = None) -> tuple[dict, dict]:
    """Write the shipped simulated bench with ``[simulation.actual]`` = ``DEVIATION`` (updated by
    ``actual_factors``: factors of the stated keys, absolute values of the others) and
    ``[simulation.defects]`` = ``defects`` to ``path``; (the stated tables, the actual table)."""
    text = example_bench_path("sim-bench").read_text()
    stated = tomllib.loads(text)
    factors = DEVIATION | (actual_factors or {})
    actual = {}
    for key, value in factors.items():
        table = stated["drive"] if key.startswith("current_loop") else stated["motor"]
        actual[key] = value * table[key] if key in table else value
    text += "\n[simulation.actual]\n" + "".join(f"{k} = {v!r}\n" for k, v in actual.items())
    if defects:
        text += "\n[simulation.defects]\n" + "".join(f"{k} = {v!r}\n" for k, v in defects.items())
    path.write_text(text)
    return stated, actual


def hil_cli(*args: str, ok=(0,)) -> str:
    """``hil ARGS`` in its own process (this interpreter), stdout; each run indexed into its
    records folder's ``results.sqlite`` (``RIPPLE_HIL_RESULTS_DB`` left out of the environment)."""
    env = {key: value for key, value in os.environ.items() if key != "RIPPLE_HIL_RESULTS_DB"}
    env["PYTHONPATH"] = os.pathsep.join(sys.path)
    proc = subprocess.run([sys.executable, "-m", "hil", *args], capture_output=True, text=True,
                          env=env, timeout=1800)
    assert proc.returncode in ok, (args, proc.returncode, proc.stdout[-3000:],
                                   proc.stderr[-3000:])
    return proc.stdout


def run_plans(bench: Path, records: Path, seed: int, sources=(), ok=(0, 1)) -> str:
    """``hil run`` of ``sources`` (every plan when empty) on ``bench``; the record ID."""
    selection = [arg for name in sources for arg in ("--source", name)]
    out = hil_cli("run", "--bench", str(bench), *selection, "--record-dir", str(records),
                  "--no-report", "--seed", str(seed), ok=ok)
    return re.search(r"^record: \S+/(\S+) \((\S+)\)$", out, re.M).group(1)


def compare(records: Path, a: str, b: str) -> dict:
    """``hil compare A B --json`` (d = b − a)."""
    return json.loads(hil_cli("compare", a, b, "--records", str(records), "--json"))


def _judged_table(result: dict) -> list[str]:
    verdict = result["reproduction"]
    lines = ["| judged point | twin ± U (%) | bench ± U (%) | d = bench − twin ± U_d (%) | "
             "\\|d\\|/U_d | |", "|---|---|---|---|---|---|"]
    for point in result["points"]:
        test_id = point["test_id"]
        if test_id not in verdict["within_u"] + verdict["beyond_u"]:
            continue
        d = point["pk_pk_pu"]
        word = "**beyond U**" if test_id in verdict["beyond_u"] else "within U"
        differs = ("" if point["outcome_a"] == point["outcome_b"] else
                   f" (verdict {point['outcome_a']} → {point['outcome_b']})")
        ratio = abs(d["difference"]) / d["u_difference"]
        lines.append(f"| `{test_id.split('/')[-1]}` | {100 * d['a']:.3f} ± {100 * d['u_a']:.3f} "
                     f"| {100 * d['b']:.3f} ± {100 * d['u_b']:.3f} | {100 * d['difference']:+.3f} "
                     f"± {100 * d['u_difference']:.3f} | {ratio:.2f} | {word}{differs} |")
    return lines


def _orders_beyond(result: dict) -> list[str]:
    judged = set(result["reproduction"]["within_u"] + result["reproduction"]["beyond_u"])
    lines = []
    for point in result["points"]:
        if point["test_id"] not in judged:
            continue
        for order in point["orders"]:
            if order["changed"]:
                lines.append(f"`{point['test_id'].split('::')[-1]}` order {order['order']:g}: "
                             f"{1000 * order['a']:.3f} → {1000 * order['b']:.3f} mN·m, d = "
                             f"{1000 * order['difference']:+.3f} ± "
                             f"{1000 * order['u_difference']:.3f} "
                             f"({order['difference'] / order['a']:+.2%})")
    return lines


def _characterisation(records: Path, ids: dict) -> list[str]:
    from hil.record import load_record

    rows = {name: {r["name"]: r for r in load_record(records / rid)["characterisation"]
                   ["stated_vs_measured"]} for name, rid in ids.items()}
    names = list(next(iter(rows.values())))
    lines = ["| parameter | stated | " + " | ".join(f"{n}: measured ± U" for n in rows) + " |",
             "|---|---|" + "---|" * len(rows)]
    for param in names:
        first = next(iter(rows.values()))[param]
        lines.append(f"| `{param}` | {first['stated']:.6g} | " + " | ".join(
            f"{r[param]['measured']:.6g} ± {r[param]['U_k2']:.2g}" for r in rows.values()) + " |")
    return lines


def section(title: str, result: dict, commands: list[str], *, table: bool = True) -> list[str]:
    verdict = result["reproduction"]
    lines = [f"## {title}", "", "```sh", *commands, "```", "",
             f"**{verdict['statement']}**", ""]
    if table:
        lines += _judged_table(result) + [""]
    if verdict["verdicts_differ"]:
        lines += ["Verdicts that differ: " + ", ".join(
            f"`{d['test_id'].split('::')[-1]}` ({d['outcome_a']} → {d['outcome_b']})"
            for d in verdict["verdicts_differ"]), ""]
    orders = _orders_beyond(result)
    lines += [f"Analysed orders of the judged points beyond their U_d (U the revolution scatter "
              f"only; not part of the statement): {len(orders)}"
              + ("." if not orders else ":"), ""] + [f"- {line}" for line in orders] + [""]
    reasons: dict[str, list[str]] = {}
    for test_id, why in verdict["not_comparable"].items():
        reasons.setdefault(why, []).append(f"`{test_id.split('::')[-1]}`")
    if reasons:
        lines += ["Judged tests not comparable:", ""] + [
            f"- {why}: {', '.join(tests)}" for why, tests in reasons.items()] + [""]
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--source", action="append", default=[], metavar="NAME")
    parser.add_argument("--workdir", type=Path)
    parser.add_argument("--no-write", action="store_true")
    args = parser.parse_args()
    root = args.workdir or Path(tempfile.mkdtemp(prefix="twin-compare-"))
    root.mkdir(parents=True, exist_ok=True)
    records, start = root / "records", time.perf_counter()
    sel = "".join(f" --source {name}" for name in args.source)
    run = f"hil run{sel} --no-report --record-dir records"

    bench, twin = root / "bench.toml", root / "twin.toml"
    deviated_bench(bench)
    hil_cli("characterize", "--bench", str(bench), "--record-dir", str(root / "characterisation"),
            "--write-twin", str(twin))
    ids = {"bench": run_plans(bench, records, 0, args.source),
           "twin": run_plans(twin, records, 1, args.source)}
    faulty = root / "bench-fault.toml"
    deviated_bench(faulty, defects=FAULT)
    ids["fault"] = run_plans(faulty, records, 2, args.source)
    ids["again"] = run_plans(bench, records, 3, args.source)
    sat, sat_twin = root / "bench-sat.toml", root / "twin-sat.toml"
    deviated_bench(sat, actual_factors=SATURATING_WARMING)
    hil_cli("characterize", "--bench", str(sat), "--record-dir", str(root / "characterisation"),
            "--write-twin", str(sat_twin))
    ids["sat"] = run_plans(sat, records, 0, args.source)
    ids["sat_twin"] = run_plans(sat_twin, records, 1, args.source)

    results = {"deviated bench against its twin": compare(records, ids["twin"], ids["bench"]),
               "extra hidden fault": compare(records, ids["twin"], ids["fault"]),
               "the bench twice": compare(records, ids["again"], ids["bench"]),
               "saturating and warming bench": compare(records, ids["sat_twin"], ids["sat"])}
    lines = ["# The user's own twin against its bench (issue 29)", "",
             f"`.venv/bin/python studies/twin_compare.py{sel}` ({time.perf_counter() - start:.0f} "
             "s wall on the shared 2-core machine, every step a `hil` command in its own "
             "process). pk-pk in % of the nameplate torque, U at k = 2, U_d = √(U_twin² + "
             "U_bench²); a judged point is a test with a verdict in either run.", "",
             "bench.toml = `hil/examples/sim-bench.toml` + `[simulation.actual]` " + ", ".join(
                 f"{k} × {v:g}" for k, v in DEVIATION.items()) + ".", "",
             "Summary (`hil compare`'s last line):", ""]
    lines += [f"- {case}: {result['reproduction']['statement']}"
              for case, result in results.items()]
    lines += ["", "The last case is a limit, not a success: saturation and warming are not carried "
              "over into the twin, and the judged pk-pk do not resolve what it lacks (its orders "
              "below; `docs/characterisation.md`).", "", "Characterisation in each `hil run`:", ""]
    lines += _characterisation(records, {"bench": ids["bench"], "twin": ids["twin"]}) + [""]
    lines += section("Deviated bench against its twin",
                     results["deviated bench against its twin"], [
        "hil characterize --bench bench.toml --write-twin twin.toml",
        f"{run} --bench bench.toml --seed 0", f"{run} --bench twin.toml --seed 1",
        "hil compare TWIN_RECORD BENCH_RECORD --records records"])
    lines += section("Extra hidden fault the twin lacks", results["extra hidden fault"], [
        "# bench-fault.toml = bench.toml + [simulation.defects] hidden_ia_offset_a = 0.3",
        f"{run} --bench bench-fault.toml --seed 2",
        "hil compare TWIN_RECORD FAULT_RECORD --records records"])
    lines += section("The bench twice (seeds 0 and 3)", results["the bench twice"], [
        f"{run} --bench bench.toml --seed 3",
        "hil compare AGAIN_RECORD BENCH_RECORD --records records"], table=False)
    lines += ["Characterisation of the saturating and warming bench and its twin:", ""]
    lines += _characterisation(records, {"bench": ids["sat"], "twin": ids["sat_twin"]}) + [""]
    lines += section("Saturating and warming bench against its twin (not carried over)",
                     results["saturating and warming bench"], [
        "# bench-sat.toml = bench.toml with phase_inductance_h the nameplate's, "
        "saturation_current_a = 40, winding_time_constant_s = 60, "
        "winding_rise_pu_per_a2 = 5e-4",
        "hil characterize --bench bench-sat.toml --write-twin twin-sat.toml",
        f"{run} --bench bench-sat.toml --seed 0", f"{run} --bench twin-sat.toml --seed 1",
        "hil compare TWIN_RECORD BENCH_RECORD --records records"])
    text = "\n".join(lines)
    print(text)
    if not args.no_write:
        RESULT.write_text(text)


if __name__ == "__main__":
    main()
