"""Every plan starts from a known drive state, checked (issue 30 item 4; fixtures/plan_state.py).

The hole: state one plan left on the drive met the next (the audit saw the diagnosis plan's
standard additions fail only after the dead-time plan). A plan module that leaves a knob set
outside ``measure`` is the simulated defect; the next plan must find it, record it, restore the
defaults and read them back — and refuse to run on a drive that keeps a value.
"""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

from hil.record import load_record
from ripple_hil_fixtures.plan_state import SECTION, ensure_known_state


def test_a_knob_left_set_is_found_recorded_and_restored(sim_bench, run_record):
    sim_bench.drive.set_injection(dead_time_s=3e-6, ia_offset_a=0.2)
    found = ensure_known_state(sim_bench, run_record, "diagnosis", {})
    assert found == {"dead_time_s": pytest.approx(3e-6), "ia_offset_a": pytest.approx(0.2)}
    assert all(value == default for value, default in sim_bench.drive.read_injections().values())
    assert run_record.data[SECTION]["diagnosis"]["restored"] is True


class _StickyDrive:
    """A drive that acknowledges the restore and keeps its dead time (unit test double)."""

    def read_injections(self):
        return {"dead_time_s": (3e-6, 0.0), "ia_offset_a": (0.0, 0.0)}


class _Bench:
    drive = _StickyDrive()

    def make_safe(self, reason):
        return None


class _Record:
    def set_section(self, name, data):
        self.section = (name, data)


def test_a_drive_that_keeps_a_value_stops_the_plan():
    record = _Record()
    with pytest.raises(RuntimeError, match="dead_time_s reads 3e-06"):
        ensure_known_state(_Bench(), record, "diagnosis", {})
    assert record.section[1]["diagnosis"]["restored"] is False


LEAKY = '''
import pytest
pytestmark = pytest.mark.ripple_source("leaky")

def test_leaves_a_knob_set(bench):
    bench.drive.set_injection(dead_time_s=3e-6)      # outside measure: nothing restores it
'''
NEXT = '''
import pytest
pytestmark = pytest.mark.ripple_source("next_plan")

def test_starts_from_the_defaults(bench):
    left = {k: v for k, (v, d) in bench.drive.read_injections().items() if v != d}
    assert not left, left
'''


def test_the_fixture_runs_before_every_plan_module(tmp_path):
    (tmp_path / "test_a_leaky.py").write_text(textwrap.dedent(LEAKY))
    (tmp_path / "test_b_next.py").write_text(textwrap.dedent(NEXT))
    records = tmp_path / "records"
    done = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                           "test_a_leaky.py", "test_b_next.py", "--hil-record", str(records)],
                          capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]
    record = load_record(sorted(p for p in records.iterdir() if p.is_dir())[-1])
    states = record[SECTION]
    assert states["leaky"]["found_off_default"] == {}
    assert states["next_plan"]["found_off_default"] == {"dead_time_s": pytest.approx(3e-6)}
    assert states["next_plan"]["restored"] is True
