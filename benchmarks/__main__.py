"""``python -m benchmarks`` (``make bench``): run every benchmark, print a table, write JSON.

Each benchmark script runs in its own process (as its docstring says to run it), so one that
fails or hangs cannot take the others with it; its printed figures are read back with the
patterns below (the scripts print for people; this keeps them free of a second output format).
The table goes to stdout, the machine-readable summary to ``benchmarks/results.json`` (or
``--json FILE``): per benchmark its command, exit code, wall time, figures (value + unit) and the
raw output, plus the machine and its load. A figure a pattern no longer finds is reported as
missing, never invented. ``--quick`` runs every benchmark on small sizes (a smoke check of the
plumbing, not figures to quote).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import subprocess
import sys
import time
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

HERE = Path(__file__).resolve().parent
DEFAULT_JSON = HERE / "results.json"
#: Figures measured before issue 17's work, each with its method (the table's "before" column).
BEFORE_JSON = HERE / "before_issue17.json"
#: One benchmark may not run longer than this, s (a stuck server must not hang ``make bench``).
TIMEOUT_S = 1800.0
_NUMBER = r"([-+]?[\d,]*\.?\d+(?:[eE][-+]?\d+)?)"


@dataclass(frozen=True)
class Pattern:
    """A printed figure: ``regex`` finds it (named groups become ``{name}`` in ``figure``)."""

    regex: str
    figure: str
    unit: str
    value_group: str = "value"
    #: A benchmark whose output lacks a required figure is reported with an error.
    required: bool = True


@dataclass(frozen=True)
class Benchmark:
    name: str
    script: str
    args: tuple[str, ...]
    quick_args: tuple[str, ...]
    patterns: tuple[Pattern, ...]
    what: str
    #: The script prints ``header:`` lines with indented ``key value`` rows under them.
    sectioned: bool = False


def _v(unit_text: str) -> str:
    """A value followed by its printed unit."""
    return rf"(?P<value>{_NUMBER[1:-1]})\s*{unit_text}"


#: The plans of the 25-point run issue 17 timed (before the ripple map and diagnosis existed).
ISSUE17_SOURCES = ("baseline", "dc_offset", "gain_mismatch", "encoder", "word_length",
                   "pwm_resolution", "pwm_switching", "dead_time")

BENCHMARKS: tuple[Benchmark, ...] = (
    Benchmark(
        "simulation", "sim_bench.py", (), ("--seconds", "0.05", "--repeats", "1"),
        (Pattern(r"(?m)^one drive, one core(?P<label>[^:\n]*?)\s*:\s*"
                 + _v(r"wall s per simulated s"), "one_drive_one_core{label}_wall_s_per_sim_s",
                 "s/s"),
         Pattern(r"batch of 16, all cores:\s*" + _v(r"wall s per simulated s of the batch"),
                 "batch_of_16_wall_s_per_sim_s", "s/s"),
         Pattern(r"batch of 16.*?,\s*" + _v(r"per drive-second"),
                 "batch_of_16_wall_s_per_drive_s", "s/s"),
         Pattern(r"first calls \(compile or cache load\):\s*" + _v("s"),
                 "first_call_compile_s", "s", required=False)),
        "digital twin: wall seconds per simulated second"),
    Benchmark(
        "analysis", "analysis_bench.py", (), ("--samples", "200000", "--repeat", "1"),
        (Pattern(r"analysis chain:.*=\s*" + _v(r"samples/s"), "analysis_samples_per_s",
                 "samples/s"),
         Pattern(r"analysis is\s*" + _v(r"x faster"), "analysis_over_capture_rate", "x")),
        "analysis chain (resample, average, spectrum, uncertainty): samples per second"),
    Benchmark(
        "canopen", "canopen_bench.py", (), ("--seconds", "0.2"),
        (Pattern(r"(?m)^(?P<section>\w+): (?P<key>\w+_per_s)\s+(?P<value>[\d.]+)$",
                 "{section}.{key}", "1/s"),
         Pattern(r"(?m)^(?P<section>\w+): (?P<key>\w+_fraction)\s+(?P<value>[\d.]+)$",
                 "{section}.{key}", "1")),
        "CANopen drive: SDO round trips and PDO frames per second (virtual and remote bus)",
        sectioned=True),
    Benchmark(
        "modbus", "modbus_bench.py", (), ("--samples", "2000", "--points-per-plan", "1"),
        (Pattern(r"(?m)^Modbus (?P<label>[^:]+): buffer paging\s*" + _v(r"registers/s"),
                 "{label} registers_per_s", "registers/s"),
         Pattern(r"(?m)^Modbus (?P<label>[^:]+): whole capture.*\(" + _v(r"samples/s"),
                 "{label} capture_samples_per_s", "samples/s"),
         Pattern(r"(?m)^Modbus run \((?P<label>\w+)\):.*projected TCP at 2 ms round trip\s*"
                 + _v("s"), "run_{label}_tcp_2ms_s", "s"),
         Pattern(r"(?m)^Modbus run \((?P<label>\w+)\):.*RTU at 115200 baud 8E1\s*" + _v("s"),
                 "run_{label}_rtu_115200_s", "s"),
         Pattern(r"(?m)^Modbus run \((?P<label>\w+)\): (?P<value>[\d,]+) requests",
                 "run_{label}_requests", "1")),
        "Modbus DAQ: transfer per plan before/after issue 17 (projected at 2 ms TCP, RTU "
        "115200 baud); registers per second (TCP loopback, RTU on a pty)"),
    Benchmark(
        "transducer", "transducer_bench.py", (), ("--samples", "500"),
        (Pattern(r"(?m)^(?P<label>\w+ [^:]+): (?P<how>polled read\(\)|stream\(\d+\)):\s*"
                 + _v(r"samples/s"), "{label} {how} samples_per_s", "samples/s"),),
        "serial torque transducer: samples per second (both dialects, unpaced and paced pty)"),
    Benchmark(
        "hil_run", "run_bench.py", ("--report", "--pdf", "--repeat", "3", "--startup"),
        ("--source", "baseline"),
        (Pattern(r"hil run \((?P<which>[^,]+(?:, [^,]+)*?), simulated bench\):\s*"
                 r"(?P<value>\d+) points", "points", "points"),
         Pattern(r"hil run .*points in\s*" + _v(r"wall s"), "wall_s", "s"),
         Pattern(r"hil run .*=\s*" + _v(r"points/s"), "points_per_s", "points/s"),
         Pattern(r"hil run .*points/s,\s*" + _v(r"CPU s"), "cpu_s", "s", required=False),
         Pattern(r"hil report on that record:\s*" + _v(r"wall s"), "report_wall_s", "s",
                 required=False),
         Pattern(r"pytest start-up and collection of one plan:\s*" + _v(r"s with every"),
                 "startup_all_plugins_s", "s", required=False),
         Pattern(r"pytest start-up and collection of one plan:.*?,\s*" + _v(r"s with hil run"),
                 "startup_hil_run_plugins_s", "s", required=False)),
        "the whole `hil run` on the simulated bench (all plans), then `hil report`"),
    Benchmark(
        "hil_run_issue17", "run_bench.py",
        ("--pdf", "--repeat", "3", *(a for s in ISSUE17_SOURCES for a in ("--source", s))),
        ("--source", "baseline"),
        (Pattern(r"hil run \((?P<which>[^,]+(?:, [^,]+)*?), simulated bench\):\s*"
                 r"(?P<value>\d+) points", "points", "points"),
         Pattern(r"hil run .*points in\s*" + _v(r"wall s"), "wall_s", "s"),
         Pattern(r"hil run .*median of \d+:\s*(?P<value>[\d.]+)", "fastest_of_3_wall_s", "s",
                 required=False)),
        "`hil run` of the 8 plans issue 17 timed (its 25 points + self-check + sensitivity "
        "checks), PDF included, median of 3 (issue 17: <= 8 s)"),
    Benchmark(
        "yield", "yield_bench.py", (), ("--quick",),
        (Pattern(r"closed form, one core:\s*" + _v(r"drives/s"), "closed_form_drives_per_s",
                 "drives/s"),
         Pattern(r"hil yield closed form, .*?2 workers:\s*" + _v(r"wall s"),
                 "closed_form_campaign_wall_s", "s"),
         Pattern(r"(?m)^twin on (?P<workers>\d+) worker\(s\):\s*" + _v(r"drive-s per wall s"),
                 "twin_{workers}_workers_drive_s_per_wall_s", "s/s"),
         Pattern(r"(?m)^dask overhead per task, (?P<workers>\d+) worker\(s\):\s*" + _v(r"ms"),
                 "dask_overhead_per_task_{workers}_workers_ms", "ms"),
         Pattern(r"N=(?P<n>\d+):\s*" + _v(r"h"), "projected_1e6_twin_drives_N{n}_h", "h",
                 required=False)),
        "yield campaigns: closed-form drives/s, twin drive-s per wall s on 1 and 2 Dask workers"),
    Benchmark(
        "results_db", "results_bench.py", (), ("--quick",),
        (Pattern(r"ingest of a 53-test run, (?P<db>\w+):\s*" + _v(r"s"), "ingest_53_tests_{db}_s",
                 "s"),
         Pattern(r"hil history \(newest 50 of \d+ runs\), (?P<db>\w+):\s*" + _v(r"s"),
                 "history_{db}_s", "s"),
         Pattern(r"hil trend --requirement over \d+ runs, (?P<db>\w+):\s*" + _v(r"s"),
                 "trend_requirement_{db}_s", "s"),
         Pattern(r"hil trend --source over \d+ runs, (?P<db>\w+):\s*" + _v(r"s"),
                 "trend_source_{db}_s", "s")),
        "results database: ingest of a 53-test run, history/trend over 10,000 synthetic runs "
        "(goal: ingest <= 0.2 s, queries <= 1 s)"),
)


def parse_figures(benchmark: Benchmark, text: str) -> dict[str, dict]:
    """Every figure the benchmark's patterns find in its output: ``{name: {value, unit}}``.

    Names are the pattern's template filled from its groups, with runs of other characters
    than letters, digits and ``.()+-`` made one ``_`` (``TCP_loopback_registers_per_s``)."""
    if benchmark.sectioned:
        text = flatten_sections(text)
    figures: dict[str, dict] = {}
    for pattern in benchmark.patterns:
        for match in re.finditer(pattern.regex, text):
            groups = {k: v.strip() for k, v in match.groupdict().items() if v is not None}
            name = re.sub(r"[^\w.()+-]+", "_", pattern.figure.format(**groups)).strip("_")
            figures[name] = {"value": float(groups[pattern.value_group].replace(",", "")),
                             "unit": pattern.unit}
    return figures


def missing_figures(benchmark: Benchmark, text: str) -> list[str]:
    """The required patterns that match nothing in the output (the script's wording changed)."""
    if benchmark.sectioned:
        text = flatten_sections(text)
    return [pattern.figure for pattern in benchmark.patterns
            if pattern.required and re.search(pattern.regex, text) is None]


def flatten_sections(text: str) -> str:
    """``virtual (in-process):`` + indented ``key value`` rows -> ``virtual: key value`` lines."""
    lines, section = [], ""
    for line in text.splitlines():
        if line[:1].strip() and line.rstrip().endswith(":"):
            section = line.split()[0].rstrip(":")
        elif line.startswith(" ") and section:
            lines.append(f"{section}: {line.strip()}")
            continue
        lines.append(line)
    return "\n".join(lines)


def run_benchmark(benchmark: Benchmark, quick: bool, timeout_s: float = TIMEOUT_S) -> dict:
    """Run one benchmark script in a subprocess; its figures, exit code and raw output."""
    command = [sys.executable, str(HERE / benchmark.script),
               *(benchmark.quick_args if quick else benchmark.args)]
    start = time.perf_counter()
    try:
        done = subprocess.run(command, capture_output=True, text=True, timeout=timeout_s,
                              cwd=HERE.parent)
        stdout, stderr, code = done.stdout, done.stderr, done.returncode
    except subprocess.TimeoutExpired as exc:
        stdout = exc.stdout.decode() if isinstance(exc.stdout, bytes) else exc.stdout or ""
        stderr, code = f"timed out after {timeout_s:g} s", None
    wall_s = time.perf_counter() - start
    figures = parse_figures(benchmark, stdout)
    result = {"what": benchmark.what, "command": [Path(c).name if i == 0 else c
                                                   for i, c in enumerate(command)],
              "returncode": code, "wall_s": wall_s, "figures": figures,
              "stdout": stdout, "stderr": stderr[-4000:]}
    missing = missing_figures(benchmark, stdout)
    if code != 0:
        result["error"] = f"exit {code}: {stderr.strip().splitlines()[-1] if stderr.strip() else ''}"
    elif missing:
        result["error"] = (f"figure(s) not found in the output: {', '.join(missing)} "
                           "(did the script's wording change?)")
    return result


def machine() -> dict:
    return {"python": platform.python_version(), "platform": platform.platform(),
            "cpu_count": os.cpu_count(), "load_average_1min_start": os.getloadavg()[0]}


def load_before(path: Path = BEFORE_JSON) -> dict[str, dict]:
    """The recorded before-figures (``{benchmark: {figure: {value, unit, command}}}``), or {}."""
    if not path.is_file():
        return {}
    return json.loads(path.read_text()).get("figures", {})


def table(results: dict[str, dict], before: dict[str, dict] | None = None) -> str:
    """The human summary: one line per figure, with its recorded before-figure where one exists
    (``before_issue17.json``: measured before issue 17's work, each by the method it states)."""
    before = before or {}
    rows = [("benchmark", "figure", "value", "unit", "before")]
    for name, result in results.items():
        for figure, item in result["figures"].items():
            old = before.get(name, {}).get(figure)
            rows.append((name, figure, _format(item["value"]), item["unit"],
                         _format(old["value"]) if old else ""))
        if "error" in result:
            rows.append((name, "ERROR", result["error"][:60], "", ""))
    widths = [max(len(row[i]) for row in rows) for i in range(5)]
    lines = [(f"{r[0]:<{widths[0]}}  {r[1]:<{widths[1]}}  {r[2]:>{widths[2]}}  "
              f"{r[3]:<{widths[3]}}  {r[4]:>{widths[4]}}").rstrip() for r in rows]
    lines.insert(1, "-" * len(lines[0]))
    return "\n".join(lines)


def _format(value: float) -> str:
    if value == int(value) and abs(value) < 1e15:
        return f"{int(value):,}"
    return f"{value:,.0f}" if abs(value) >= 1000 else f"{value:.4g}"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("--json", metavar="FILE", type=Path, default=DEFAULT_JSON,
                        help=f"JSON summary to write (default {DEFAULT_JSON.relative_to(HERE.parent)})")
    parser.add_argument("--only", action="append", metavar="NAME",
                        choices=[b.name for b in BENCHMARKS],
                        help="run only this benchmark (repeatable)")
    parser.add_argument("--quick", action="store_true",
                        help="small sizes: checks the plumbing, figures not for quoting")
    parser.add_argument("--timeout-s", type=float, default=TIMEOUT_S,
                        help=f"per-benchmark time limit (default {TIMEOUT_S:g} s)")
    args = parser.parse_args(argv)
    selected = [b for b in BENCHMARKS if not args.only or b.name in args.only]
    summary = {"created_utc": datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
               "quick": args.quick, "machine": machine(), "benchmarks": {}}
    for benchmark in selected:
        print(f"running {benchmark.name}: {benchmark.what} ...", file=sys.stderr, flush=True)
        summary["benchmarks"][benchmark.name] = run_benchmark(benchmark, args.quick,
                                                              args.timeout_s)
    summary["machine"]["load_average_1min_end"] = os.getloadavg()[0]
    args.json.parent.mkdir(parents=True, exist_ok=True)
    args.json.write_text(json.dumps(summary, indent=2) + "\n")
    before = load_before()
    summary["before"] = before
    print(table(summary["benchmarks"], before))
    if before:
        print(f"before: {BEFORE_JSON.name}: figures quoted from session 2's note, measured "
              f"against commit {json.loads(BEFORE_JSON.read_text())['commit']} before issue "
              "17's work; each figure's method is stated there (not all are today's method)")
    m = summary["machine"]
    print(f"\n{m['cpu_count']} cores, load average {m['load_average_1min_start']:.2f} -> "
          f"{m['load_average_1min_end']:.2f}{' (QUICK sizes)' if args.quick else ''}; "
          f"JSON: {args.json}")
    failed = [name for name, result in summary["benchmarks"].items() if "error" in result]
    if failed:
        print(f"benchmarks with errors: {', '.join(failed)}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
