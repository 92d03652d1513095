"""A requirement measured inside its ILAC-G8 guard band: statement 1, the overall, the test's
pytest outcome, the summary and the exit status agree, end to end: the guarded rule (binary
statement with guard band, ILAC-G8:09/2019 §4.2.2) rejects it, so FAIL, naming the requirement
as inside the guard band.

``hil run --source baseline`` on the simulated bench runs twice: once with a far limit to learn
the measured value and its U, then with the limit half a U above that value. The second run's
record must hold a "conditional pass"-zone verdict (checked, not assumed), and page 1, the
record's statement and the terminal summary must all say FAIL for it, with the zone named.
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

from pypdf import PdfReader

from hil.record import load_record
from record_factory import requirement_verdict, self_check_entry
from ripple_hil_reports.statement import (CONDITIONAL_PASS, FAIL, NOT_STATED, PASS,
                                          overall_statement)

REQUIREMENT = '''
[[requirement]]
id = "REQ-G1"
name = "total ripple, drive as delivered"
quantity = "pk_pk_pct"
limit = {{ max = {limit!r} }}
source = ["baseline"]
injected = "none"
rule = "{rule}"
'''


def run_baseline(tmp_path: Path, name: str, limit: float, rule: str = "guarded"):
    """``hil run --source baseline`` with REQ-G1 at ``limit`` %: (REQ-G1's verdict, the record,
    the report's pages as text with whitespace folded, the finished process)."""
    spec = tmp_path / f"{name}.toml"
    spec.write_text(REQUIREMENT.format(limit=limit, rule=rule))
    records = tmp_path / name
    done = subprocess.run([sys.executable, "-m", "hil", "run", "--source", "baseline",
                           "--requirements", str(spec), "--record-dir", str(records)],
                          capture_output=True, text=True, timeout=180, cwd=tmp_path)
    (folder,) = [path for path in records.iterdir() if path.is_dir()]
    record = load_record(folder)
    (verdict,) = [r for t in record["tests"] for r in t.get("requirements") or []]
    pages = [re.sub(r"\s+", " ", page.extract_text().replace("\u200b", ""))
             for page in PdfReader(folder / "report.pdf").pages]
    return verdict, record, pages, done


def test_a_requirement_inside_the_guard_band_is_a_fail_of_the_guarded_rule_everywhere(tmp_path):
    probe, _, _, done = run_baseline(tmp_path, "probe", 100.0)
    assert done.returncode == 0 and probe["decision"] == "pass", done.stdout[-2000:]
    limit = probe["measured"] + 0.5 * probe["expanded_uncertainty"]
    verdict, record, pages, done = run_baseline(tmp_path, "guarded", limit)
    page = pages[0]
    assert verdict["measured"] == probe["measured"]            # the seeded bench repeats
    assert verdict["decision"] == "conditional pass" and not verdict["accepted"]

    statement = overall_statement(record, [])
    zone = "REQ-G1 (inside the guard band: within the limit by less than U, not accepted by the " \
           "guarded rule)"
    assert statement.requirements == f"{FAIL}: {zone}"
    assert statement.overall == FAIL and "requirement(s) not met: REQ-G1" in statement.reason
    assert statement.model_text == "baseline: PASS"      # the model verdict stands apart
    assert f"1. Requirements conformity {FAIL}: {zone}" in page
    assert f"Overall: {FAIL} (" in page and "requirement(s) not met: REQ-G1" in page
    assert NOT_STATED not in page and CONDITIONAL_PASS not in page
    # the requirements table names the zone and that the rule did not accept it
    table = next(text for text in pages[1:] if "REQ-G1" in text)
    assert "CONDITIONALPASS:notaccepted" in re.sub(r"\s+", "", table)
    assert "not accepted: REQ-G1" in done.stdout and f"overall: {FAIL}" in done.stdout
    assert done.returncode == 1      # the plan's test failed on the rejected requirement
    (baseline,) = [t for t in record["tests"] if t["source"] == "baseline"]
    assert baseline["outcome"] == "failed"


def test_the_simple_rule_accepts_the_same_value_and_beyond_the_limit_is_a_fail():
    inside = requirement_verdict("REQ-G1", 2.0, 2.05, u=0.1)          # limit − measured < U
    assert inside["decision"] == "conditional pass"
    simple = inside | {"rule": "simple", "accepted": True}
    checked = self_check_entry(True)
    point = {"test_id": "b", "source": "baseline", "kind": "measurement", "outcome": "passed",
             "verdict": {"decision": "pass"}}
    stated = overall_statement({"status": "complete",
                                "tests": [checked, point | {"requirements": [simple]}]}, [])
    assert (stated.requirements, stated.overall) == (PASS, PASS)
    beyond = requirement_verdict("REQ-G2", 2.0, 1.95, u=0.1)           # measured − limit < U
    assert beyond["decision"] == "conditional fail"
    stated = overall_statement({"status": "complete",
                                "tests": [checked, point | {"requirements": [beyond]}]}, [])
    assert stated.requirements == f"{FAIL}: REQ-G2 (beyond the limit by less than U)"
    assert stated.overall == FAIL
