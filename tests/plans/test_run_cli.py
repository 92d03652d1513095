"""``hil run`` refuses bad input before the bench opens, always runs the bench self-check, and
takes the Ctrl-C path on SIGTERM (bench safe, record closed as interrupted)."""

import json
import signal
import subprocess
import sys
import time

from hil.cli import build_parser
from hil.commands.run import build_pytest_args
from hil.record import load_record

HIL = [sys.executable, "-m", "hil"]


def test_a_source_selection_always_includes_the_self_check(tmp_path):
    args = build_parser(["run"]).parse_args(["run", "--source", "dc_offset", "--no-report"])
    files = [a for a in build_pytest_args(args) if a.endswith(".py")]
    assert [f.rsplit("/", 1)[-1] for f in files] == ["test_self_check.py", "test_dc_offset.py"]


def test_negative_seed_and_unwritable_report_are_refused_before_anything_starts(tmp_path):
    existing = tmp_path / "old.pdf"
    existing.write_bytes(b"%PDF-1.4 earlier report")
    for extra, message in ((["--seed", "-1"], "is negative"),
                           (["-o", str(existing)], "never overwritten"),
                           (["-o", str(tmp_path / "no" / "x.pdf")], "does not exist")):
        done = subprocess.run(HIL + ["run", "--source", "baseline", "--record-dir",
                                     str(tmp_path / "rec"), *extra],
                              capture_output=True, text=True, timeout=120, cwd=tmp_path)
        assert done.returncode == 2, done.stderr
        assert done.stderr.count("\n") == 1 and message in done.stderr
        assert not (tmp_path / "rec").exists()
    assert existing.read_bytes() == b"%PDF-1.4 earlier report"


def test_sigterm_takes_the_ctrl_c_path(tmp_path):
    records = tmp_path / "rec"
    run = subprocess.Popen(HIL + ["run", "--source", "dc_offset", "--source", "ripple_map",
                                  "--no-report", "--record-dir", str(records)],
                           stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                           cwd=tmp_path)
    try:
        deadline = time.monotonic() + 180
        while time.monotonic() < deadline:
            journals = list(records.glob("*/journal.jsonl"))
            if journals and sum(_is_test(line) for line in
                                journals[0].read_text().splitlines()) >= 2:
                break
            time.sleep(0.02)
        run.send_signal(signal.SIGTERM)
        output, _ = run.communicate(timeout=60)
    finally:
        if run.poll() is None:
            run.kill()
    assert run.returncode == 2, output[-2000:]
    record = load_record(next(records.iterdir()))
    assert record["status"] == "interrupted", output[-2000:]
    assert any(t["outcome"] == "not run" for t in record["tests"])


def _is_test(line: str) -> bool:
    try:
        return json.loads(line).get("event") == "test"
    except json.JSONDecodeError:
        return False
