"""The unit under test's serial is a first-class field (issue 32 item 2): ``hil run --dut-serial``
is checked against the drive's CiA 301 serial number (0x1018:04, written as the bench file's
``[drive] serial_label``) before the drive is driven; a mismatch is refused (exit 2, one line, no
record) unless an override is given, which the record and page 1 state; the serial is the
database's DUT column, found by ``hil history --dut``."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from pypdf import PdfReader

from hil.config import example_bench_path
from hil.record import load_record

pytestmark = [pytest.mark.slow, pytest.mark.timeout(300)]


def hil(*args: str, cwd) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k != "RIPPLE_HIL_RESULTS_DB"}
    env["PYTHONPATH"] = os.pathsep.join(sys.path)
    return subprocess.run([sys.executable, "-m", "hil", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=240)


@pytest.fixture
def labelled_bench(tmp_path) -> Path:
    """The simulated bench whose drive reports serial number 2, labelled EPS-A-0002."""
    text = example_bench_path("sim-bench").read_text()
    assert text.count("[drive]\n") == 1
    bench = tmp_path / "labelled.toml"
    bench.write_text(text.replace("[drive]\n", '[drive]\nserial_label = "EPS-A-{serial:04d}"\n')
                     + "\n[simulation.drive_identity]\nserial = 2\nvendor = 0x0000ABCD\n")
    return bench


def test_a_serial_that_is_not_the_drives_is_refused_before_the_drive_is_driven(
        tmp_path, labelled_bench):
    done = hil("run", "--bench", str(labelled_bench), "--source", "baseline", "--no-report",
               "--dut-serial", "EPS-A-0003", "--record-dir", "records", cwd=tmp_path)
    assert done.returncode == 2, (done.stdout[-2000:], done.stderr[-2000:])
    lines = [line for line in (done.stdout + done.stderr).splitlines()
             if "refused, nothing driven" in line]
    assert len(lines) == 1 and "EPS-A-0003" in lines[0] and "EPS-A-0002" in lines[0]
    assert not [p for p in (tmp_path / "records").glob("*") if p.is_dir()]   # no record


def test_an_override_is_recorded_on_page_1_and_the_serial_is_the_dut_column(
        tmp_path, labelled_bench):
    done = hil("run", "--bench", str(labelled_bench), "--source", "baseline",
               "--dut-serial", "EPS-A-0003", "--dut-serial-override", "label reprinted",
               "--record-dir", "records", cwd=tmp_path)
    assert done.returncode == 0, (done.stdout[-2000:], done.stderr[-2000:])
    folder = next(p for p in (tmp_path / "records").iterdir() if p.is_dir())
    dut = load_record(folder)["dut"]
    assert dut["serial"] == "EPS-A-0003" and dut["check"] == "mismatch, overridden"
    assert dut["override"] == "label reprinted"
    assert dut["drive_identity"]["serial"] == 2 and dut["drive_identity"]["vendor"] == 0xABCD
    page = re.sub(r"\s+", " ", PdfReader(folder / "report.pdf").pages[0].extract_text())
    assert "unit EPS-A-0003 (--dut-serial)" in page and "override: label reprinted" in page
    assert "serial number 2" in page
    listed = hil("history", "--records", "records", "--dut", "EPS-A-0003", "--json",
                 cwd=tmp_path)
    assert listed.returncode == 0, listed.stderr
    runs = json.loads(listed.stdout)["runs"]
    assert [r["record_id"] for r in runs] == [folder.name]
