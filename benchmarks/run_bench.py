"""Benchmark of the whole ``hil run`` on the simulated bench: wall seconds, points, points/s.

Run: ``.venv/bin/python benchmarks/run_bench.py [--source NAME ...] [--report] [--pdf]
[--repeat N] [--startup] [--json FILE]``. ``hil run`` is started as a user starts it (its own
process: pytest, the plugin, the simulated instruments over their real transports, the record on
disk) into a temporary record folder, which is removed afterwards. The points and their outcomes
are read from the record it wrote. With ``--report`` the PDF report is timed separately (``hil
report`` on the same record); with ``--pdf`` the run writes its PDF itself (``hil run -o``), as a
user's run does; ``--repeat N`` prints the median of N runs. ``--startup`` times pytest's start-up
and collection of one plan with every installed pytest plugin and with ``hil run``'s set (issue 17
item 6: hypothesis's plugin alone was ~1 s).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

HIL = [sys.executable, "-m", "hil"]
#: No single run may take longer than this (a stuck bench must not hang ``make bench``), s.
RUN_TIMEOUT_S = 1800.0


def time_hil_run(sources: list[str] | None = None, *, report: bool = False, pdf: bool = False,
                 timeout_s: float = RUN_TIMEOUT_S) -> dict:
    """Run ``hil run`` on the simulated bench in a subprocess; return its figures.

    Keys: ``wall_s`` (the whole command, process start to exit), ``cpu_s`` (user + system CPU
    seconds of the run's process and its children: steadier than the wall time on a shared or
    throttled machine, but blind to waits), ``points`` (test entries in the
    record), ``points_per_s``, ``outcomes`` (count per outcome), ``returncode``, ``record_status``
    and, with ``report``, ``report_wall_s`` (``hil report`` on the finished record).
    """
    with tempfile.TemporaryDirectory(prefix="ripple-hil-bench-") as scratch:
        records = Path(scratch) / "records"
        command = HIL + ["run", "--record-dir", str(records)] + (
            ["-o", str(Path(scratch) / "run.pdf")] if pdf else ["--no-report"])
        for source in sources or []:
            command += ["--source", source]
        env = dict(os.environ, PYTHONUNBUFFERED="1")
        cpu_before = _children_cpu_s()
        start = time.perf_counter()
        done = subprocess.run(command, capture_output=True, text=True, timeout=timeout_s,
                              cwd=scratch, env=env)
        wall_s = time.perf_counter() - start
        cpu_s = _children_cpu_s() - cpu_before
        folders = sorted(p.parent for p in records.glob("*/record.json"))
        if not folders:
            raise RuntimeError(f"hil run wrote no record (exit {done.returncode}): "
                               f"{(done.stdout + done.stderr)[-2000:]}")
        from hil.record import load_record

        record = load_record(folders[-1])
        tests = record["tests"]
        figures = {"wall_s": wall_s, "cpu_s": cpu_s, "points": len(tests),
                   "points_per_s": len(tests) / wall_s if wall_s > 0 else float("nan"),
                   "outcomes": dict(Counter(t["outcome"] for t in tests)),
                   "returncode": done.returncode, "record_status": record["status"],
                   "sources": sorted({t["source"] for t in tests if t.get("source")})}
        if report:
            start = time.perf_counter()
            again = ["--reason", "benchmark: report timed again"] if pdf else []
            rendered = subprocess.run(HIL + ["report", str(folders[-1]), "-o",
                                             str(Path(scratch) / "report.pdf"), *again],
                                      capture_output=True, text=True, timeout=timeout_s)
            figures["report_wall_s"] = time.perf_counter() - start
            figures["report_returncode"] = rendered.returncode
    return figures


def _children_cpu_s() -> float:
    """User + system CPU seconds of this process's finished children."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def time_startup(repeat: int = 3) -> dict:
    """Best-of-``repeat`` wall seconds of ``pytest --collect-only`` of the baseline plan, with
    every installed pytest plugin and with the set ``hil run`` loads."""
    from hil.commands.run import plan_modules, unrelated_plugins

    plan = str(plan_modules()["baseline"])
    base = [sys.executable, "-m", "pytest", "--collect-only", "-q", "-p", "no:cacheprovider", plan]
    out = {}
    for name, extra in (("all_plugins", []), ("hil_run_plugins", unrelated_plugins())):
        best = float("inf")
        for _ in range(repeat):
            start = time.perf_counter()
            subprocess.run(base + extra, capture_output=True, text=True, timeout=300)
            best = min(best, time.perf_counter() - start)
        out[name] = best
    return out


def time_record_writes(record_dir: Path) -> dict:
    """Write the tests of a finished record again, as a run writes them (a capture saved, then
    the entry, per test): with the journal (each event one appended line, the summary once) and
    the way format 1 did it (the whole record.json rewritten atomically after every event)."""
    from hil.capture import Capture, atomic_write_bytes
    from hil.config import default_sim_bench
    from hil.record import RunRecord, load_record

    source = load_record(record_dir)
    tests = [t for t in source["tests"] if t.get("capture")]
    captures = {t["test_id"]: Capture.load(record_dir / t["capture"]["file"]) for t in tests}
    entries = [{k: v for k, v in t.items() if k != "capture"} for t in source["tests"]]
    with tempfile.TemporaryDirectory(prefix="ripple-hil-records-") as scratch:
        start = time.perf_counter()
        record = RunRecord.create(scratch, default_sim_bench(), [], name="journal")
        for entry in entries:
            if entry["test_id"] in captures:
                record.save_capture(entry["test_id"], captures[entry["test_id"]])
            record.add_test(entry)
        record.finish("complete")
        journal_s = time.perf_counter() - start
        start = time.perf_counter()
        data = dict(source, tests=[])
        folder = Path(scratch) / "rewrite"
        for entry in entries:
            if entry["test_id"] in captures:
                captures[entry["test_id"]].save(folder / "captures" / f"{len(data['tests'])}.npz")
                atomic_write_bytes(folder / "record.json", json.dumps(data, indent=2).encode())
            data["tests"].append(entry)
            atomic_write_bytes(folder / "record.json", json.dumps(data, indent=2).encode())
        rewrite_s = time.perf_counter() - start
    return {"tests": len(entries), "journal_s": journal_s, "rewrite_s": rewrite_s,
            "record_json_bytes": (record_dir / "record.json").stat().st_size}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--source", action="append", metavar="NAME",
                        help="run only this source's plan (repeatable); default: all plans")
    parser.add_argument("--report", action="store_true",
                        help="also time `hil report` on the record")
    parser.add_argument("--pdf", action="store_true",
                        help="the run writes its PDF itself (hil run -o), as a user's run does")
    parser.add_argument("--repeat", type=int, default=1, metavar="N",
                        help="run N times and print the median wall time (default 1)")
    parser.add_argument("--startup", action="store_true",
                        help="also time pytest start-up with all plugins and with hil run's")
    parser.add_argument("--record-writes", action="store_true",
                        help="also time writing a run's record with the journal and by "
                             "rewriting record.json per event (format 1)")
    parser.add_argument("--json", metavar="FILE", help="also write the figures as JSON here")
    args = parser.parse_args(argv)
    runs = [time_hil_run(args.source, report=args.report, pdf=args.pdf)
            for _ in range(max(1, args.repeat))]
    walls = sorted(run["wall_s"] for run in runs)
    cpus = sorted(run["cpu_s"] for run in runs)
    figures = runs[0] | {"wall_s": walls[len(walls) // 2], "wall_s_all": walls,
                         "cpu_s": cpus[len(cpus) // 2], "cpu_s_all": cpus}
    figures["points_per_s"] = figures["points"] / figures["wall_s"]
    which = ", ".join(args.source) if args.source else "all plans"
    outcomes = ", ".join(f"{n} {name}" for name, n in sorted(figures["outcomes"].items()))
    print(f"hil run ({which}, simulated bench): {figures['points']} points in "
          f"{figures['wall_s']:.2f} wall s = {figures['points_per_s']:.3f} points/s, "
          f"{figures['cpu_s']:.2f} CPU s "
          f"(exit {figures['returncode']}, record {figures['record_status']}; {outcomes}"
          f"{'; PDF written by the run' if args.pdf else ''}"
          f"{f'; median of {len(walls)}: ' + ', '.join(f'{w:.2f}' for w in walls) if len(walls) > 1 else ''}"
          f"{f'; CPU s: ' + ', '.join(f'{c:.2f}' for c in cpus) if len(cpus) > 1 else ''})")
    if "report_wall_s" in figures:
        print(f"hil report on that record: {figures['report_wall_s']:.2f} wall s "
              f"(exit {figures['report_returncode']})")
    if args.record_writes:
        with tempfile.TemporaryDirectory(prefix="ripple-hil-bench-") as scratch:
            records = Path(scratch) / "records"
            subprocess.run(HIL + ["run", "--no-report", "--record-dir", str(records)] + [
                arg for source in args.source or [] for arg in ("--source", source)],
                capture_output=True, text=True, timeout=RUN_TIMEOUT_S, cwd=scratch)
            writes = time_record_writes(next(records.glob("*/record.json")).parent)
        figures["record_writes"] = writes
        print(f"record writes for {writes['tests']} tests (record.json "
              f"{writes['record_json_bytes'] / 1e6:.2f} MB): {writes['journal_s']:.2f} s with "
              f"the journal, {writes['rewrite_s']:.2f} s rewriting record.json per event")
    if args.startup:
        startup = time_startup()
        figures["startup"] = startup
        print(f"pytest start-up and collection of one plan: {startup['all_plugins']:.2f} s with "
              f"every installed plugin, {startup['hil_run_plugins']:.2f} s with hil run's")
    if args.json:
        Path(args.json).write_text(json.dumps(figures, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
