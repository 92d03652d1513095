"""Page 1 states the bench the record says ran the tests: simulated in this process, simulated in
a separate process (``hil sim-bench``) at its addresses, or real. End to end: a one-test plan run
by pytest against an in-process bench and against simulated instruments served by another
"process" (this one, over CAN-over-TCP, Modbus TCP and a pty, exactly as ``hil sim-bench``
serves them), each with the PDF; and the wording for a real bench and for an older record."""

from __future__ import annotations

import json
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from pypdf import PdfReader

from hil.bench import Bench
from hil.commands.sim_bench import bench_file_text
from hil.config import default_sim_bench, example_bench_path, load_bench
from hil.simbench import SimulatedBench
from ripple_hil_reports.bench_kind import bench_text

PLAN = textwrap.dedent('''
    def test_the_bench_opens(bench):
        assert bench.config.simulated
''')


def run_plan(tmp_path: Path, *options: str) -> tuple[dict, str]:
    """Run the one-test plan with the PDF; the record and page 1's text (whitespace folded)."""
    plan = tmp_path / "test_plan.py"
    plan.write_text(PLAN)
    records, pdf = tmp_path / "records", tmp_path / "report.pdf"
    done = subprocess.run([sys.executable, "-m", "pytest", str(plan), "-q", "-p",
                           "no:cacheprovider", "--hil-record", str(records), "--hil-report",
                           str(pdf), *options], capture_output=True, text=True, timeout=120,
                          cwd=tmp_path)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    (folder,) = [path for path in records.iterdir() if path.is_dir()]
    record = json.loads((folder / "record.json").read_text())
    page = PdfReader(pdf).pages[0].extract_text().replace("\u200b", "")
    return record, re.sub(r"\s+", " ", page)


def test_an_in_process_bench_is_stated_as_such(tmp_path):
    record, page = run_plan(tmp_path)
    assert record["run"]["bench_location"]["kind"] == "simulated-in-process"
    assert "simulated bench started inside this test run" in page
    assert "separate process" not in page and "in-process simulation" not in page


def test_a_separate_sim_bench_is_stated_with_its_addresses(tmp_path):
    served = SimulatedBench(default_sim_bench(), seed=2, cross_process=True)
    config = served.start()
    try:
        bench_file = tmp_path / "sim.toml"
        bench_file.write_text(bench_file_text(config.to_dict()))
        record, page = run_plan(tmp_path, "--hil-bench", str(bench_file))
    finally:
        served.stop()
    location = record["run"]["bench_location"]
    assert location["kind"] == "simulated-separate-process"
    assert "simulated bench served by a separate process" in page
    assert "started inside this test run" not in page and "in-process" not in page
    daq = f"Modbus TCP {config.daq.host}:{config.daq.port}"
    assert daq in location["addresses"]["daq"] and daq in page
    assert config.torque.serial_port in page


def test_a_real_bench_is_located_from_its_bench_file():
    config = load_bench(example_bench_path("real-bench"))
    location = Bench(config, drive=None, daq=None, torque=None).location()
    assert location["kind"] == "real"
    record = {"bench": {"simulated": False, "path": "bench.toml"},
              "run": {"bench_location": location}}
    text = bench_text(record)
    assert text.startswith("real bench at drive: CANopen node")
    assert "DAQ: Modbus TCP 192.168.10.20:502 unit 1" in text
    assert "transducer: serial port /dev/ttyUSB0" in text and text.endswith("; file bench.toml")
    assert "simulated" not in text


@pytest.mark.parametrize("simulated, words", [
    (True, "simulated bench (the record does not say in which process); file b.toml"),
    (False, "real bench; file b.toml"),
])
def test_a_record_without_a_location_claims_no_more_than_it_holds(simulated, words):
    assert bench_text({"bench": {"simulated": simulated, "path": "b.toml"}, "run": {}}) == words
