"""Benchmark of the whole ``hil run`` on the simulated bench: wall seconds, points, points/s.

Run: ``.venv/bin/python benchmarks/run_bench.py [--source NAME ...] [--report] [--json FILE]``.
``hil run`` is started as a user starts it (its own process: pytest, the plugin, the simulated
instruments over their real transports, the record on disk) into a temporary record folder, which
is removed afterwards. The points and their outcomes are read from the record it wrote. With
``--report`` the PDF report is written too and its share of the time is measured separately
(``hil report`` on the same record).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

HIL = [sys.executable, "-m", "hil"]
#: No single run may take longer than this (a stuck bench must not hang ``make bench``), s.
RUN_TIMEOUT_S = 1800.0


def time_hil_run(sources: list[str] | None = None, *, report: bool = False,
                 timeout_s: float = RUN_TIMEOUT_S) -> dict:
    """Run ``hil run`` on the simulated bench in a subprocess; return its figures.

    Keys: ``wall_s`` (the whole command, process start to exit), ``points`` (test entries in the
    record), ``points_per_s``, ``outcomes`` (count per outcome), ``returncode``, ``record_status``
    and, with ``report``, ``report_wall_s`` (``hil report`` on the finished record).
    """
    with tempfile.TemporaryDirectory(prefix="ripple-hil-bench-") as scratch:
        records = Path(scratch) / "records"
        command = HIL + ["run", "--no-report", "--record-dir", str(records)]
        for source in sources or []:
            command += ["--source", source]
        env = dict(os.environ, PYTHONUNBUFFERED="1")
        start = time.perf_counter()
        done = subprocess.run(command, capture_output=True, text=True, timeout=timeout_s,
                              cwd=scratch, env=env)
        wall_s = time.perf_counter() - start
        folders = sorted(p.parent for p in records.glob("*/record.json"))
        if not folders:
            raise RuntimeError(f"hil run wrote no record (exit {done.returncode}): "
                               f"{(done.stdout + done.stderr)[-2000:]}")
        record = json.loads((folders[-1] / "record.json").read_text())
        tests = record["tests"]
        figures = {"wall_s": wall_s, "points": len(tests),
                   "points_per_s": len(tests) / wall_s if wall_s > 0 else float("nan"),
                   "outcomes": dict(Counter(t["outcome"] for t in tests)),
                   "returncode": done.returncode, "record_status": record["status"],
                   "sources": sorted({t["source"] for t in tests if t.get("source")})}
        if report:
            start = time.perf_counter()
            rendered = subprocess.run(HIL + ["report", str(folders[-1]), "-o",
                                             str(Path(scratch) / "report.pdf")],
                                      capture_output=True, text=True, timeout=timeout_s)
            figures["report_wall_s"] = time.perf_counter() - start
            figures["report_returncode"] = rendered.returncode
    return figures


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--source", action="append", metavar="NAME",
                        help="run only this source's plan (repeatable); default: all plans")
    parser.add_argument("--report", action="store_true",
                        help="also time `hil report` on the record")
    parser.add_argument("--json", metavar="FILE", help="also write the figures as JSON here")
    args = parser.parse_args(argv)
    figures = time_hil_run(args.source, report=args.report)
    which = ", ".join(args.source) if args.source else "all plans"
    outcomes = ", ".join(f"{n} {name}" for name, n in sorted(figures["outcomes"].items()))
    print(f"hil run ({which}, simulated bench): {figures['points']} points in "
          f"{figures['wall_s']:.2f} wall s = {figures['points_per_s']:.3f} points/s "
          f"(exit {figures['returncode']}, record {figures['record_status']}; {outcomes})")
    if "report_wall_s" in figures:
        print(f"hil report on that record: {figures['report_wall_s']:.2f} wall s "
              f"(exit {figures['report_returncode']})")
    if args.json:
        Path(args.json).write_text(json.dumps(figures, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
