"""Page 1 = the record (issue 22 item 3, design.md §7): one fold over the tests
(``reports.statement.source_states``) gives every selected source its worst state, including
points not run or not determined; a FAIL that happened is FAIL whatever the run status; a run
without requirements says so in its overall line; a SIGTERM is not called Ctrl-C. The summary
prints the same derivation."""

from __future__ import annotations

from hil.outcome_kinds import MEASURED, NOT_DETERMINABLE, not_determinable
from record_factory import requirement_verdict, self_check_entry
from ripple_hil_fixtures.summary import summary_lines
from ripple_hil_reports.content import _section
from ripple_hil_reports.statement import (FAIL, NOT_STATED, PASS, overall_statement,
                                          run_status_text, source_states)


def point(test_id: str, source: str, decision: str | None = "pass", outcome: str = "passed",
          **extra) -> dict:
    return {"test_id": test_id, "source": source, "kind": "measurement", "outcome": outcome,
            "verdict": {"decision": decision} if decision else None} | extra


def not_run(test_id: str, source: str) -> dict:
    return {"test_id": test_id, "source": source, "outcome": "not run",
            "message": "not run: the run was interrupted"}


def record(*tests: dict, status: str = "complete", **top) -> dict:
    return {"status": status, "tests": [self_check_entry(True), *tests]} | top


def test_an_interrupted_source_is_not_determined_and_an_unrun_source_is_listed():
    """The issue's Ctrl-C run: 3 of 5 encoder points done, dead time never started. Page 1 said
    "encoder: PASS" and left dead time off; page 2 said NOT DETERMINED."""
    tests = [point(f"e{i}", "encoder") for i in range(3)] + [not_run(f"e{i}", "encoder")
                                                             for i in (3, 4)]
    tests += [not_run(f"d{i}", "dead_time") for i in range(4)]
    stated = overall_statement(record(*tests, status="interrupted"), None)
    assert stated.model == {"encoder": "not determined", "dead_time": "not run"}
    assert stated.model_text == ("encoder: NOT DETERMINED (3 pass, 2 not run); "
                                 "dead_time: NOT RUN (4 not run)")
    assert stated.overall == NOT_STATED and "interrupted (Ctrl-C)" in stated.reason
    # the source page reads the same state (one derivation)
    assert _section("encoder", tests[:5]).statement == "not determined"
    assert any(line == "  encoder: NOT DETERMINED (3 pass, 2 not run)"
               for line in summary_lines(record(*tests, status="interrupted")))


def test_a_failure_that_happened_is_fail_in_any_run_status():
    tests = (point("e0", "encoder"), point("e1", "encoder", "fail", "failed"),
             not_run("e2", "encoder"))
    for status in ("interrupted", "stopped", "aborted"):
        stated = overall_statement(record(*tests, status=status), None)
        assert stated.overall == FAIL, status
        assert stated.model["encoder"] == "fail"
        assert "1 test(s) failed or errored; the rest is not stated" in stated.reason
    text = " ".join(" ".join(summary_lines(record(*tests, status="stopped"))).split())
    assert "overall: FAIL (1 test(s) failed or errored; the rest is not stated (stopped" in text


def test_a_not_determinable_point_makes_a_complete_run_not_stated_not_pass():
    skipped = point("w3", "word_length", None, NOT_DETERMINABLE,
                    message=not_determinable("12 bit: the ripple is below the bench's floor"))
    stated = overall_statement(record(point("w1", "word_length"), skipped), [])
    assert stated.model == {"word_length": "not determined"}
    assert stated.overall == NOT_STATED and "not determined: word_length" in stated.reason
    assert any("below the bench's floor" in r for r in stated.sources["word_length"].reasons)


def test_measured_points_are_neither_passes_nor_a_model_verdict():
    cells = [point(f"m{i}", "ripple_map", None, MEASURED, kind="ripple_map") for i in range(3)]
    stated = overall_statement(record(point("b", "baseline"), *cells), [])
    assert stated.model == {"baseline": "pass", "ripple_map": MEASURED}
    assert stated.overall == PASS
    row = next(line for line in summary_lines(record(point("b", "baseline"), *cells))
               if line.startswith("ripple_map")).split()
    assert row[1:2] == ["3"] and row[2] == "0" and row[-3] == "3"   # pts, pass, meas.
    # judged by requirements only: statement 1 states them, statement 2 does not
    judged = point("m9", "ripple_map", None, "passed",
                   requirements=[requirement_verdict("REQ-1", 2.0, 3.0)])
    assert source_states(record(judged))["ripple_map"].state == "no model verdict"


def test_a_default_run_without_requirements_says_so_in_the_overall_line():
    stated = overall_statement(record(point("b", "baseline"), point("o", "dc_offset")), [])
    assert (stated.overall, stated.reason) == (
        PASS, "model validation and self-check; no requirements given")
    with_requirement = point("b", "baseline",
                             requirements=[requirement_verdict("REQ-1", 2.0, 30.0)])
    stated = overall_statement(record(with_requirement, requirements={"lines": [
        {"id": "REQ-1"}]}), [])
    assert (stated.overall, stated.reason) == (
        PASS, "requirements, model validation and self-check")


def test_a_requirement_that_judged_no_point_is_not_stated_beside_one_that_passed():
    """The issue's typo: two lines, one judged and passing, one on plan "basline" judged
    nothing. It said "requirements: 1 verdicts, all pass" and "Requirements conformity PASS"."""
    judged = point("b", "baseline", requirements=[requirement_verdict("REQ-A", 2.0, 3.0)])
    given = {"lines": [{"id": "REQ-A"}, {"id": "REQ-B"}]}
    stated = overall_statement(record(judged, requirements=given), [])
    assert stated.requirements.startswith(NOT_STATED) and "REQ-B" in stated.requirements
    assert (stated.requirements_given, stated.requirements_judged) == (2, 1)
    assert stated.overall == NOT_STATED and "REQ-B" in stated.reason
    assert "requirements: 2 given, 1 judged, 1 verdicts; NOT STATED, judged no point: REQ-B" \
        in summary_lines(record(judged, requirements=given))


def test_a_sigterm_is_not_called_ctrl_c():
    interrupted = {"status": "interrupted", "tests": []}
    assert run_status_text(interrupted) == "interrupted (Ctrl-C)"
    # the record's "interruption" section, as fixtures.session writes it
    assert run_status_text(interrupted | {"interruption": {"signal": "SIGINT"}}) \
        == "interrupted (Ctrl-C)"
    text = run_status_text(interrupted | {"interruption": {"signal": "SIGTERM"}})
    assert text.startswith("terminated (SIGTERM)") and "Ctrl-C" not in text
    assert run_status_text({"status": "terminated"}).startswith("terminated (SIGTERM)")
    stated = overall_statement(record(point("b", "baseline"), status="interrupted",
                                      interruption={"signal": "SIGTERM"}), None)
    assert stated.run.startswith("terminated (SIGTERM)") and "Ctrl-C" not in stated.reason
