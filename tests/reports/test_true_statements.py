"""Only true statements (issue 32 Build 5), from the one fold ``reports.statement``: a test
stopped by a lost bench is not determined, never a FAIL of its plan or of the run; a run that
judged nothing is counted as such (``hil run`` exits 9); every sink counts the tests once, in
the record's words."""

from __future__ import annotations

from hil.outcome_kinds import MEASURED, NOT_DETERMINABLE
from record_factory import requirement_verdict, self_check_entry
from ripple_hil_fixtures.summary import summary_lines
from ripple_hil_reports.statement import (FAIL, NOT_STATED, judged_tests, outcome_counts,
                                          overall_statement)

ABORT = {"instrument": "drive", "error": "InstrumentTimeout: no SDO answer within 0.5 s",
         "step": "test_vanish.py::test_point[0.3] (call): set injection ia_offset_a=0.3"}


def point(offset: str, outcome: str, decision: str | None, message: str | None = None) -> dict:
    test_id = f"test_vanish.py::test_point[{offset}]"
    return {"test_id": test_id, "nodeid": test_id, "source": "dc_offset", "kind": "measurement",
            "outcome": outcome, "message": message,
            "verdict": {"decision": decision} if decision else None}


def lost_run(first_decision: str = "pass") -> dict:
    """As the in-process bench that vanishes at the third point writes it (tests/integration/
    test_truth.py): two points judged, the third stopped by the loss, two not run."""
    return {"status": "aborted", "run": {"abort": ABORT}, "tests": [
        point("0.1", "passed" if first_decision == "pass" else "failed", first_decision),
        point("0.2", "passed", "pass"),
        point("0.3", "failed", None, "bench lost: drive during test_vanish.py::test_point[0.3] "
                                     "(call), set injection ia_offset_a=0.3"),
        point("0.4", "not run", None, "not run: bench lost (drive: InstrumentTimeout)"),
        point("0.5", "not run", None, "not run: bench lost (drive: InstrumentTimeout)")]}


def test_a_lost_bench_is_not_stated_never_a_fail():
    record = lost_run()
    stated = overall_statement(record, [])
    assert stated.overall == NOT_STATED and "aborted: the bench was lost" in stated.reason
    assert stated.sources["dc_offset"].state == "not determined"
    assert stated.bad_tests == []
    text = "\n".join(summary_lines(record))
    assert "FAIL" not in text, text
    assert "dc_offset: NOT DETERMINED" in text and "overall: NOT STATED" in text
    # the loss is named by the step alone too (a message cut or rewritten)
    record["tests"][2]["message"] = "InstrumentTimeout"
    assert overall_statement(record, []).overall == NOT_STATED


def test_a_failure_before_the_loss_is_still_stated():
    """The fold still can say FAIL on an aborted run: a point that failed its verdict before
    the bench was lost is a failure that happened."""
    stated = overall_statement(lost_run(first_decision="fail"), [])
    assert stated.overall == FAIL and stated.sources["dc_offset"].state == "fail"
    assert stated.bad_tests == ["test_vanish.py::test_point[0.1]"]
    # without an abort section the same failed test is a fail (the loss is not assumed)
    record = lost_run()
    record["run"] = {}
    record["tests"][2]["message"] = "InstrumentTimeout"
    assert overall_statement(record, []).overall == FAIL


def test_what_a_run_judged():
    measured = {"test_id": "m", "source": "ripple_map", "outcome": MEASURED}
    refused = {"test_id": "n", "source": "dc_offset", "outcome": NOT_DETERMINABLE}
    judged = {"test_id": "j", "source": "dc_offset", "outcome": "passed",
              "verdict": {"decision": "pass"}}
    by_requirement = measured | {"outcome": "passed",
                                 "requirements": [requirement_verdict("REQ-1", 2.0, 30.0)]}
    plain = {"test_id": "p", "source": "coupling", "outcome": "passed"}
    nothing = [measured, refused, self_check_entry(True)]
    assert judged_tests({"tests": nothing}) == 0
    assert judged_tests(lost_run() | {"tests": lost_run()["tests"][2:]}) == 0
    for one in (judged, by_requirement, plain):
        assert judged_tests({"tests": [*nothing, one]}) == 1
    # a plan check across the sweep judges its source (it can fail it)
    assert judged_tests({"tests": nothing, "ripple_map_trend": {
        "statement": "x", "accepted": False}}) == 1


def test_one_count_in_the_records_words():
    """Each test once (the self-check's ``-reference`` measurement is part of its test), in the
    words pytest's own line uses; the summary and page 1 print exactly this."""
    reference = self_check_entry(True) | {"test_id": "s::t-reference", "nodeid": "s::t"}
    tests = [self_check_entry(True) | {"test_id": "s::t", "nodeid": "s::t"}, reference,
             {"test_id": "a", "nodeid": "a", "source": "ripple_map", "outcome": MEASURED},
             {"test_id": "b", "nodeid": "b", "source": "dc_offset", "outcome": "failed"},
             {"test_id": "c", "nodeid": "c", "source": "dc_offset", "outcome": "not run"}]
    counts = outcome_counts({"tests": tests})
    assert counts == {"passed": 1, "failed": 1, MEASURED: 1, "not run": 1}
    assert list(counts) == ["passed", "failed", MEASURED, "not run"]
    lines = summary_lines({"status": "complete", "tests": tests})
    assert "tests: 1 passed, 1 failed, 1 measured, no verdict, 1 not run" in lines
    assert overall_statement({"tests": tests}, None).counts == counts


def test_a_test_stopped_by_a_full_disk_is_not_a_fail():
    record = lost_run()
    record["status"] = "storage-error"
    record["run"] = {"storage_error": {"path": "journal.jsonl", "errno_name": "ENOSPC",
                                       "step": "test_vanish.py::test_point[0.3] (call)"}}
    record["tests"][2]["message"] = "record storage failed: cannot write journal.jsonl"
    stated = overall_statement(record, [])
    assert stated.overall == NOT_STATED and stated.bad_tests == []
    assert "FAIL" not in "\n".join(summary_lines(record))
