"""End to end on the simulated bench (``hil run --source ripple_map``): the ripple-map cells
judge nothing, so the record keeps them "measured, no verdict", the summary counts them apart
from the passes, and page 1 states them apart; a user requirement that applies to some cells
makes those judged (passed) instead (issue 21 item 6)."""

from __future__ import annotations

import re
import subprocess
import sys
import textwrap

import pytest
from pypdf import PdfReader

import hil.record
from hil.outcome_kinds import MEASURED
from hil.record import load_record
from ripple_hil_testplans.conditions import RIPPLE_MAP_SPEEDS_RPM

pytestmark = pytest.mark.skipif(
    MEASURED not in hil.record.OUTCOMES,
    reason="hil.record.OUTCOMES does not list the hil.outcome_kinds words yet (merge step)")


def test_ripple_map_cells_are_measured_unless_a_requirement_judges_them(tmp_path):
    judged_speed = RIPPLE_MAP_SPEEDS_RPM[0]
    spec = tmp_path / "spec.toml"
    spec.write_text(textwrap.dedent(f'''
        [[requirement]]
        id = "REQ-M"
        name = "total ripple, drive as it is"
        quantity = "pk_pk_pct"
        limit = {{ max = 50.0 }}
        source = "ripple_map"
        speed_rpm = {judged_speed}
        '''))
    records = tmp_path / "records"
    done = subprocess.run([sys.executable, "-m", "hil", "run", "--source", "ripple_map",
                           "--requirements", str(spec), "--record-dir", str(records)],
                          capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert done.returncode == 0, done.stdout[-3000:]
    (folder,) = [path for path in records.iterdir() if path.is_dir()]
    cells = [t for t in load_record(folder)["tests"] if t.get("kind") == "ripple_map"]
    judged = [t for t in cells if t["operating_point"]["speed_rpm"] == judged_speed]
    assert judged and {t["outcome"] for t in judged} == {"passed"}
    assert all(t["requirements"] for t in judged)
    measured = [t for t in cells if t not in judged]
    assert measured and {t["outcome"] for t in measured} == {MEASURED}
    row = next(line for line in done.stdout.splitlines() if line.startswith("ripple_map"))
    assert row.split()[1:3] == [str(len(cells)), str(len(judged))]        # points, pass
    assert row.split()[-3] == str(len(measured))                          # meas.
    page1 = re.sub(r"\s+", " ", PdfReader(folder / "report.pdf").pages[0].extract_text())
    assert f"ripple_map: NO MODEL VERDICT ({len(judged)} no model verdict, {len(measured)} " \
           f"measured, no verdict)" in page1
