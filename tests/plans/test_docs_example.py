"""The worked example of docs/writing-plans.md runs as written on the simulated bench."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

DOC = Path(__file__).parents[2] / "docs" / "writing-plans.md"

pytestmark = [pytest.mark.integration]


def blocks(language: str) -> list[str]:
    return re.findall(rf"```{language}\n(.*?)```", DOC.read_text(encoding="utf-8"), re.S)


def test_the_documented_user_plan_runs_and_judges_its_requirements(tmp_path):
    (tmp_path / "test_eps_production.py").write_text(blocks("python")[0])
    (tmp_path / "my-spec.toml").write_text(blocks("toml")[0])
    records = tmp_path / "records"
    done = subprocess.run([sys.executable, "-m", "pytest", "test_eps_production.py", "-q",
                           "-p", "no:cacheprovider", "--hil-requirements", "my-spec.toml",
                           "--hil-record", str(records)],
                          capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]
    (folder,) = records.iterdir()
    from hil.record import load_record

    tests = load_record(folder)["tests"]
    measured = [t for t in tests if t.get("measured")]
    assert len(measured) == 3
    for test in measured:
        ids = sorted(r["id"] for r in test["requirements"])
        assert ids == ["CUST-EPS-7-4.2a", "CUST-EPS-7-4.2b"], json.dumps(test["requirements"])
        assert all(r["accepted"] for r in test["requirements"])
