"""Study: the same plans on the same simulated drive, captured by the Modbus DAQ and by the
simulated oscilloscope (issue 31 item 3): same verdicts, pk-pk within the combined U?

Run: ``.venv/bin/python studies/scope_vs_daq.py [--source NAME …] [--out DIR]`` (default: every
plan ``hil run`` knows). Two ``hil run`` of the shipped simulated bench, seed 0, one with
``[acquisition] kind = "scpi-scope"`` (``[daq] timeout_s = 5`` in both: a loaded machine); then
per judged test: both decisions, both pk-pk per unit, |difference| against
U_d = √(U_daq² + U_scope²). Prints a Markdown table and the counts.
"""

from __future__ import annotations

import argparse
import math
import subprocess
import sys
import tempfile
from pathlib import Path

from hil.record import load_record

SIM_BENCH = Path(__file__).resolve().parents[1] / "hil" / "examples" / "sim-bench.toml"


def run(folder: Path, scope: bool, sources: list[str]) -> dict:
    text = SIM_BENCH.read_text().replace("[daq]\n", "[daq]\ntimeout_s = 5.0\n", 1)
    bench = folder / ("scope.toml" if scope else "daq.toml")
    bench.write_text(text + ('\n[acquisition]\nkind = "scpi-scope"\n' if scope else ""))
    records = folder / bench.stem
    selection = [arg for source in sources for arg in ("--source", source)]
    subprocess.run([sys.executable, "-m", "hil", "run", "--bench", str(bench), "--record-dir",
                    str(records), "--no-report", "--results-db", "off", *selection],
                   capture_output=True, text=True, timeout=7200, check=False)
    (record,) = [p for p in records.iterdir() if (p / "record.json").exists()]
    return load_record(record)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--source", action="append", default=[])
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args()
    folder = args.out or Path(tempfile.mkdtemp(prefix="scope-vs-daq-"))
    folder.mkdir(parents=True, exist_ok=True)
    daq, scope = run(folder, False, args.source), run(folder, True, args.source)
    by_id = {test["test_id"]: test for test in daq["tests"]}
    rows, same, within, judged = [], 0, 0, 0
    for test in scope["tests"]:
        other = by_id.get(test["test_id"])
        if other is None or not (test.get("verdict") and other.get("verdict")):
            continue
        judged += 1
        a, b = test["measured"]["pk_pk_pu"], other["measured"]["pk_pk_pu"]
        u = math.hypot(test["uncertainty"]["expanded_pu"], other["uncertainty"]["expanded_pu"])
        agree = test["verdict"]["decision"] == other["verdict"]["decision"]
        same += agree
        within += abs(a - b) <= u
        rows.append(f"| {test['test_id'].split('::')[-1]} | {other['verdict']['decision']} | "
                    f"{test['verdict']['decision']} | {b:.5f} | {a:.5f} | {abs(a - b):.5f} | "
                    f"{u:.5f} |")
    print(f"records: {folder}")
    print("| test | DAQ | scope | pk-pk DAQ (pu) | pk-pk scope (pu) | diff | U_d |")
    print("|---|---|---|---|---|---|---|")
    print("\n".join(rows))
    print(f"\njudged tests: {judged}; same decision: {same}; |diff| <= U_d: {within}; "
          f"outcomes DAQ run {daq['status']}, scope run {scope['status']}")
    return 0 if same == judged else 1


if __name__ == "__main__":
    sys.exit(main())
