"""The rule printed on a source page is the rule its verdicts recorded (issue 22 item 5: the
PWM-resolution page said "guard band w = U (ILAC-G8)" while the record said simple acceptance),
and a skipped or not-determinable point prints its recorded reason, never "no reason"."""

from __future__ import annotations

from hil.outcome_kinds import NOT_DETERMINABLE, not_determinable
from ripple_hil_reports.build import reason_of, rule_text, source_statement
from ripple_hil_reports.content import _section

SIMPLE = {"rel_tol": 0.0, "abs_tol_pu": 0.001, "guard_band_factor": 0.0, "expected_range": True}
GUARDED = {"rel_tol": 0.2, "abs_tol_pu": 0.002, "guard_band_factor": 1.0}


def entry(test_id: str, rule: dict, decision: str = "pass", **extra) -> dict:
    return {"test_id": test_id, "outcome": "passed", "injection": {"pwm_period_counts": 32},
            "verdict": {"decision": decision, "rule": rule, "measured_pk_pk_pu": 0.01}} | extra


def test_the_recorded_simple_rule_is_printed_not_a_guard_band():
    text = source_statement(_section("pwm_resolution", [entry("a", SIMPLE), entry("b", SIMPLE)]))
    assert text.startswith("PASS:") and "ILAC-G8 simple acceptance (w = 0" in text
    assert "guard band" not in text
    guarded = source_statement(_section("dc_offset", [entry("a", GUARDED)]))
    assert "guard band w = U (ILAC-G8 guarded acceptance)" in guarded
    assert rule_text([SIMPLE, GUARDED, SIMPLE]) == (
        "ILAC-G8 simple acceptance (w = 0; U reported beside each point); guard band w = U "
        "(ILAC-G8 guarded acceptance)")
    assert rule_text([GUARDED | {"guard_band_factor": 2.0}]).startswith("guard band w = 2·U")
    assert rule_text([None]) == "no rule recorded"


def test_a_skip_prints_its_recorded_reason():
    reason = not_determinable("the exponent straddles its band")
    skipped = {"test_id": "s", "outcome": NOT_DETERMINABLE, "message": reason, "notes": []}
    assert reason_of(skipped) == reason
    assert reason_of({"error": "TimeoutError: DAQ"}) == "TimeoutError: DAQ"
    assert reason_of({}) == "no reason recorded"
    section = _section("pwm_resolution", [entry("a", SIMPLE), skipped])
    assert section.statement == "not determined"
    assert any(reason in line for line in section.reasons)


def test_a_point_without_a_verdict_is_worded_once_on_its_source_page():
    """1000 rpm / 30 A dead-time page: each not-determinable point was listed twice, the second
    time as 'not determinable: not determinable here: …'. The list under the points table words
    it as the statement's reasons, so the lines already listed above it are left out."""
    from ripple_hil_reports.build import _unfinished_line

    reason = not_determinable("dead time 4e-06 s at 1000 rpm / 30 A: pulses are dropped")
    skipped = {"test_id": "t.py::test_dead_time[4e-06]", "outcome": NOT_DETERMINABLE,
               "message": reason}
    section = _section("dead_time", [entry("a", GUARDED), skipped])
    point = next(p for p in section.points if p.outcome == NOT_DETERMINABLE)
    line = _unfinished_line(point)
    assert line == f"test_dead_time[4e-06]: {reason}"
    assert "not determinable: not determinable" not in line
    assert line in section.reasons          # so the page does not print it a second time
    errored = _unfinished_line(next(p for p in _section("dead_time", [
        {"test_id": "t.py::e", "outcome": "error", "error": "TimeoutError: DAQ"}]).points))
    assert errored == "e: error: TimeoutError: DAQ"


def test_deviations_word_a_not_determinable_test_once():
    from ripple_hil_reports.content import deviations

    reason = not_determinable("dead time 4e-06 s at 1000 rpm / 30 A: pulses are dropped")
    record = {"status": "complete", "tests": [
        {"test_id": "t::nd", "outcome": NOT_DETERMINABLE, "message": reason},
        {"test_id": "t::e", "outcome": "error", "phase": "setup", "error": "TimeoutError: DAQ"}]}
    lines = deviations(record, [], [])
    assert f"Test 't::nd': {reason}" in lines
    assert "Test 't::e' error in setup: TimeoutError: DAQ" in lines
    assert not any("not determinable: not determinable" in line for line in lines)
