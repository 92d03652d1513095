"""A plan's own check across its points (the PWM-resolution noise check, record section
``pwm_resolution_noise``) is stated on the plan's source page of the report, accepted or not,
end to end through ``hil run --source pwm_resolution`` on the simulated bench: the correct drive
and one that applies the PWM counter at 1.5× the commanded counts (test-only defect)."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest
from pypdf import PdfReader

from hil.record import load_record
from ripple_hil_reports.statement import plan_checks


def run_pwm_resolution(tmp_path: Path, *extra: str):
    records = tmp_path / "records"
    done = subprocess.run([sys.executable, "-m", "hil", "run", "--source", "pwm_resolution",
                           "--record-dir", str(records), *extra],
                          capture_output=True, text=True, timeout=300, cwd=tmp_path)
    (folder,) = [path for path in records.iterdir() if path.is_dir()]
    record = load_record(folder)
    pages = [re.sub(r"\s+", " ", page.extract_text().replace("\u200b", ""))
             for page in PdfReader(folder / "report.pdf").pages]
    return done, record, pages


def source_page(pages: list[str]) -> str:
    return next(page for page in pages if "Source: pwm_resolution" in page)


def test_rejected_checks_name_the_sensitivity_check_and_plan_checks():
    from ripple_hil_reports.statement import rejected_checks

    record = {"sensitivity": {"dead_time": {"accepted": False}, "encoder": {"accepted": True}},
              "dead_time_noise": {"statement": "y", "accepted": False}}
    assert rejected_checks(record, "dead_time") == ["sensitivity", "noise"]
    assert rejected_checks(record, "encoder") == []
    assert rejected_checks({}, "encoder") == []


def test_plan_checks_are_the_sections_named_after_the_source():
    record = {"pwm_resolution_noise": {"statement": "C=32: ...", "accepted": True},
              "pwm_resolution_other": {"no": "statement"}, "sensitivity": {"statement": "x"},
              "dead_time_noise": {"statement": "y", "accepted": False}}
    assert [name for name, _ in plan_checks(record, "pwm_resolution")] == ["noise"]
    assert plan_checks(record, "encoder") == []


@pytest.mark.parametrize("defect, accepted", [(None, True), ("injection_scale=1.5", False)])
def test_the_noise_check_is_stated_on_the_source_page(tmp_path, defect, accepted):
    done, record, pages = run_pwm_resolution(
        tmp_path, *(("--sim-defect", defect) if defect else ()))
    check = record["pwm_resolution_noise"]
    assert check["accepted"] is accepted, done.stdout[-3000:]
    assert (done.returncode == 0) is accepted, done.stdout[-3000:]
    page = source_page(pages)
    # the source's statement and page 1's model validation follow the check, not only the
    # points (a rejected check has no point verdict of its own)
    statement = "PASS" if accepted else "FAIL"
    assert f"Statement: {statement}" in page, page
    assert f"pwm_resolution: {statement}" in pages[0], pages[0]
    # the rule printed is the rule recorded (simple acceptance), never "guard band w = U"
    if not accepted:
        assert "ILAC-G8 simple acceptance (w = 0" in page and "guard band w = U" not in page
    # a skip prints its recorded reason, never "no reason"
    assert "no reason" not in page
    verdict = "ACCEPTED" if accepted else "NOT ACCEPTED"
    assert f"Noise check (" in page and f": {verdict}." in page, page
    first = check["points"][0]
    assert f"C={first['pwm_period_counts']}: " in page
