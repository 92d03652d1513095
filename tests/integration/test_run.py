"""`hil run` end to end on the simulated bench, and a run interrupted by Ctrl-C.

Both run in a subprocess, as a user would: the real plugin, the real protocol stacks over real
transports, the real record on disk.
"""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from pypdf import PdfReader

from hil.record import load_record, verify_captures

HIL = [sys.executable, "-m", "hil"]


def only_record(root: Path) -> Path:
    folders = [p for p in root.iterdir() if (p / "record.json").exists()]
    assert len(folders) == 1, folders
    return folders[0]


def test_hil_run_records_every_point_and_writes_the_report(tmp_path):
    report = tmp_path / "report.pdf"
    done = subprocess.run(HIL + ["run", "--source", "baseline", "--source", "dc_offset",
                                 "--source", "dead_time",
                                 "--record-dir", str(tmp_path / "records"), "-o", str(report)],
                          capture_output=True, text=True, timeout=600, cwd=tmp_path)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    assert "ripple-hil summary" in done.stdout
    assert "dc_offset" in done.stdout and f"report: {report}" in done.stdout
    folder = only_record(tmp_path / "records")
    record = load_record(folder)
    assert record["status"] == "complete"
    assert [t["source"] for t in record["tests"]].count("dc_offset") == 5
    assert all(t["verdict"]["decision"] == "pass" for t in record["tests"])
    dead_time = [t for t in record["tests"] if t["source"] == "dead_time"]
    assert len(dead_time) == 3 and all(t["notes"] for t in dead_time)
    assert record["decision_rule"]["closed_form"]["rel_tol"] == 0.2
    assert verify_captures(folder, record) == []
    text = " ".join(page.extract_text() for page in PdfReader(report).pages).replace("\n", " ")
    assert "Plan's expectation (dead_time)" in text
    assert "the paper's own form gives" in text      # its eq 38 figure beside the measured one


def test_unknown_source_is_a_one_line_error(tmp_path):
    done = subprocess.run(HIL + ["run", "--source", "magic"], capture_output=True, text=True,
                          timeout=120, cwd=tmp_path)
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1 and "--source magic" in done.stderr


def test_ctrl_c_mid_sweep_keeps_every_finished_point(tmp_path):
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    process = subprocess.Popen(
        HIL + ["run", "--source", "dc_offset", "--source", "gain_mismatch", "--no-report",
               "--record-dir", str(tmp_path / "records")],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd=tmp_path, env=env)
    try:
        record_json = None
        deadline = time.monotonic() + 300
        while time.monotonic() < deadline:      # wait until two points are on disk
            folders = list((tmp_path / "records").glob("*/record.json"))
            if folders:
                record_json = folders[0]
                try:
                    if len(json.loads(record_json.read_text())["tests"]) >= 2:
                        break
                except (json.JSONDecodeError, KeyError):
                    pass
            time.sleep(0.05)
        else:
            pytest.fail("the run never recorded two points")
        process.send_signal(signal.SIGINT)
        output, _ = process.communicate(timeout=120)
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode != 0
    record = load_record(record_json.parent)
    assert record["status"] == "interrupted", output[-2000:]
    finished = [t for t in record["tests"] if t["outcome"] in ("passed", "failed")]
    assert len(finished) >= 2
    assert len(finished) < 8, "the run was not interrupted mid-sweep"
    assert verify_captures(record_json.parent, record) == []
    # an interrupted record still gives a report
    report = tmp_path / "partial.pdf"
    done = subprocess.run(HIL + ["report", str(record_json.parent), "-o", str(report)],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert report.read_bytes().startswith(b"%PDF")
