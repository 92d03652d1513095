"""Requirements that cannot silently apply to nothing (issue 22 item 2): by default a line judges
the drive as it is (``injected = "none"``), not the faults the plans inject on purpose; a plan
name that is no plan, or a line whose selected plans have no point it applies to, is refused at
pre-flight with one line naming the requirement (``hil run``: exit 2, no record, nothing sent)."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

from hil.errors import InputError
from hil.measurement import PointPlan
from hil.requirements import requirement_from_dict, scope_problems

KNOWN = {"baseline", "encoder", "dc_offset", "ripple_map", "self_check"}


def line(**overrides):
    table = {"id": "REQ-1", "name": "total ripple", "quantity": "pk_pk_pct", "limit": {"max": 2.0}}
    return requirement_from_dict(table | overrides)


def plan(source: str, injection: dict, speed_rpm: float = 500.0, current_a: float = 20.0):
    return PointPlan(source=source, injection=injection, speed_rpm=speed_rpm,
                     current_a=current_a, rule=None)


POINTS = {"b": plan("baseline", {}), "o1": plan("dc_offset", {"ia_offset_a": 0.2}),
          "o2": plan("dc_offset", {"ia_offset_a": 0.4}),
          "e": plan("encoder", {"encoder_decimation": 100}, speed_rpm=12.0)}


def test_a_line_judges_the_drive_as_it_is_by_default():
    """The issue's "total ripple ≤ 2 % at 500 rpm 20 A" without injected = ...: it failed 13
    tests, judged on the faults the plans inject on purpose (the default was "any")."""
    req = line(speed_rpm=500.0, current_a=20.0)
    assert req.injected == "none"
    where = {"source": "dc_offset", "speed_rpm": 500.0, "current_a": 20.0}
    assert not req.applies(**where, injection={"ia_offset_a": 0.2})
    assert req.applies(**where, injection={})
    assert line(injected="any").applies(**where, injection={"ia_offset_a": 0.2})
    production = line(injection={"encoder_decimation": 100})      # names the injection: wants it
    assert production.injected == "any"
    assert production.applies(source="encoder", speed_rpm=12, current_a=20,
                              injection={"encoder_decimation": 100})
    with pytest.raises(InputError, match="contradicts injection"):
        line(injected="none", injection={"encoder_decimation": 100})


def test_an_unknown_plan_name_is_refused_naming_the_allowed_ones():
    problems = scope_problems([line(id="REQ-B", source="basline")], POINTS,
                              selected={"baseline"}, known=KNOWN)
    assert len(problems) == 1
    assert problems[0].startswith("requirement REQ-B: source 'basline' is not a test plan; "
                                  "allowed: baseline, dc_offset, encoder")


def test_a_line_that_applies_to_no_selected_point_is_refused():
    injected_only = line(id="REQ-C", source="dc_offset")
    (problem,) = scope_problems([injected_only], POINTS, selected={"dc_offset"}, known=KNOWN)
    assert "REQ-C" in problem and "applies to no point of the selected plan(s) dc_offset" \
        in problem and 'give injected = "any"' in problem
    elsewhere = line(id="REQ-D", speed_rpm=777.0)
    (problem,) = scope_problems([elsewhere], POINTS, selected={"baseline", "dc_offset"},
                                known=KNOWN)
    assert "REQ-D" in problem and "500 rpm" in problem and "injected" not in problem.split(")")[-1]


def test_lines_that_apply_or_whose_plans_are_not_selected_pass_preflight():
    lines = [line(id="A", source="baseline"), line(id="B", source="dc_offset", injected="any"),
             line(id="C", injection={"encoder_decimation": 100}, speed_rpm=12.0),
             line(id="D", source="ripple_map")]                   # not selected: statement 1
    assert scope_problems(lines, POINTS, selected={"baseline", "dc_offset", "encoder"},
                          known=KNOWN) == []
    # a selected plan whose points the pre-flight cannot build: not judged by the others alone
    assert scope_problems([line(id="E", speed_rpm=777.0)], POINTS, selected={"baseline"},
                          known=KNOWN, measured_elsewhere={"baseline"}) == []


def test_hil_run_refuses_a_misspelled_plan_before_the_bench_is_touched(tmp_path):
    spec = tmp_path / "spec.toml"
    spec.write_text(textwrap.dedent('''
        [[requirement]]
        id = "REQ-A"
        name = "total ripple"
        quantity = "pk_pk_pct"
        limit = { max = 3.0 }
        source = "baseline"

        [[requirement]]
        id = "REQ-B"
        name = "total ripple"
        quantity = "pk_pk_pct"
        limit = { max = 0.01 }
        source = "basline"
        '''))
    records = tmp_path / "records"
    done = subprocess.run([sys.executable, "-m", "hil", "run", "--source", "baseline",
                           "--requirements", str(spec), "--record-dir", str(records),
                           "--no-report"], capture_output=True, text=True, timeout=120,
                          cwd=tmp_path)
    out = done.stdout + done.stderr
    assert done.returncode == 2, out
    assert "requirement REQ-B: source 'basline' is not a test plan; allowed: baseline" in out
    assert not records.exists()
