"""`hil run` with an oscilloscope as the acquisition instrument (issue 31 item 3): the simulated
SCPI scope on the same simulated drive gives the verdicts the Modbus DAQ gives, each measured
pk-pk within the two runs' combined U; and with the scope, a drive that mis-scales its injection
still fails the plan (the verdict can fail whichever instrument captured)."""

import json
import math
import subprocess
import sys
from pathlib import Path

from hil.capture import Capture
from hil.record import capture_path, load_record

HIL = [sys.executable, "-m", "hil"]
SIM_BENCH = Path(__file__).resolve().parents[2] / "hil" / "examples" / "sim-bench.toml"


def bench(tmp_path: Path, scope: bool) -> Path:
    """The shipped simulated bench (its DAQ timeout raised: two runs share a loaded machine),
    capturing with the simulated scope when ``scope``."""
    text = SIM_BENCH.read_text().replace("[daq]\n", "[daq]\ntimeout_s = 5.0\n", 1)
    path = tmp_path / ("scope-bench.toml" if scope else "daq-bench.toml")
    path.write_text(text + ('\n[acquisition]\nkind = "scpi-scope"\n' if scope else ""))
    return path


def run(tmp_path: Path, name: str, *extra: str) -> subprocess.Popen:
    return subprocess.Popen(HIL + ["run", "--source", "baseline", "--source", "dc_offset",
                                   "--record-dir", str(tmp_path / name), "--no-report",
                                   "--results-db", "off",
                                   "--bench", str(bench(tmp_path, name == "scope")), *extra],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            cwd=tmp_path)


def record_of(process: subprocess.Popen, folder: Path) -> tuple[int, dict, Path, str]:
    output, _ = process.communicate(timeout=600)
    assert folder.is_dir(), output[-3000:]
    (record_dir,) = [p for p in folder.iterdir() if (p / "record.json").exists()]
    return process.returncode, load_record(record_dir), record_dir, output


def test_scope_gives_the_daqs_verdicts_within_u(tmp_path):
    runs = {"daq": run(tmp_path, "daq"),
            "scope": run(tmp_path, "scope")}
    results = {name: record_of(process, tmp_path / name) for name, process in runs.items()}
    for name, (code, record, _, output) in results.items():
        assert code == 0, f"{name}: {output[-3000:]}"
        assert record["status"] == "complete"
    daq, scope = results["daq"][1], results["scope"][1]
    by_id = {test["test_id"]: test for test in daq["tests"]}
    judged = 0
    for test in scope["tests"]:
        other = by_id[test["test_id"]]
        assert test["outcome"] == other["outcome"], test["test_id"]
        if test.get("verdict"):
            judged += 1
            assert test["verdict"]["decision"] == other["verdict"]["decision"], test["test_id"]
            a, b = test["measured"]["pk_pk_pu"], other["measured"]["pk_pk_pu"]
            u = math.hypot(test["uncertainty"]["expanded_pu"], other["uncertainty"]["expanded_pu"])
            assert abs(a - b) <= u, (test["test_id"], a, b, u)
    assert judged == 6                              # the baseline and five dc-offset points
    entry = next(t for t in scope["tests"] if t.get("verdict"))
    capture = Capture.load(capture_path(results["scope"][2], entry["capture"]["file"]))
    assert capture.meta["source"] != "daq" and capture.meta["scope_model"] == "SIM-SCOPE-8"
    scope_row = next(row for row in scope["instruments"] if row["role"] == "acquisition")
    assert scope_row["identity"]["model"] == "SIM-SCOPE-8"


def test_with_the_scope_a_mis_scaled_injection_still_fails(tmp_path):
    process = subprocess.Popen(
        HIL + ["run", "--source", "dc_offset", "--bench", str(bench(tmp_path, scope=True)),
               "--record-dir", str(tmp_path / "bad"), "--no-report", "--results-db", "off",
               "--sim-defect", "injection_scale=1.5"],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd=tmp_path)
    code, record, _, output = record_of(process, tmp_path / "bad")
    assert code != 0, output[-2000:]
    decisions = [t["verdict"]["decision"] for t in record["tests"] if t.get("verdict")]
    assert decisions and "fail" in decisions, json.dumps(decisions)
