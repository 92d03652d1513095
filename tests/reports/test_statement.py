"""What a run may state (reports.statement, fixtures.summary) on small synthetic records: a failed
or unfinished self-check voids the other verdicts, nothing judged is never PASS, and the summary
counts each test by its outcome."""

from __future__ import annotations

from hil.outcome_kinds import MEASURED
from ripple_hil_fixtures.summary import summary_lines
from record_factory import requirement_verdict, self_check_entry
from ripple_hil_reports.statement import NOT_STATED, PASS, overall_statement


def measured(test_id: str, source: str, decision: str, outcome: str = "passed",
             requirements: list | None = None) -> dict:
    return {"test_id": test_id, "source": source, "kind": "measurement", "outcome": outcome,
            "verdict": {"decision": decision}, "requirements": requirements or []}


def record(*tests: dict, status: str = "complete", **top) -> dict:
    return {"status": status, "tests": list(tests)} | top


def test_a_good_run_passes():
    stated = overall_statement(record(self_check_entry(True), measured("a", "baseline", "pass",
                               requirements=[requirement_verdict("REQ-1", 2.0, 30.0)])), [])
    assert (stated.overall, stated.requirements, stated.self_check) == (PASS, PASS, PASS)
    assert stated.model_text == "baseline: PASS"


def test_a_failed_self_check_voids_requirements_and_models():
    tests = (self_check_entry(False),
             measured("a", "baseline", "pass",
                      requirements=[requirement_verdict("REQ-1", 2.0, 30.0)]),
             measured("b", "dc_offset", "pass"))
    stated = overall_statement(record(*tests), [])
    assert stated.self_check.startswith("FAILED")
    assert stated.requirements.startswith(NOT_STATED) and "voided" in stated.requirements
    assert stated.model_text.startswith(NOT_STATED) and "PASS" not in stated.model_text
    assert stated.overall == NOT_STATED and "self-check FAILED" in stated.reason
    text = "\n".join(summary_lines(record(*tests)))
    assert "all pass" not in text
    assert "model validation: NOT STATED" in text and "overall: NOT STATED" in text


def test_a_self_check_stopped_by_a_lost_bench_is_not_completed_not_failed():
    lost = self_check_entry(True) | {"outcome": "failed", "checks": [],
                                     "message": "TransportLost: DAQ link reset"}
    stated = overall_statement(record(lost, measured("a", "baseline", "pass"), status="aborted",
                                      run={"abort": {"instrument": "daq"}}), [])
    assert stated.self_check.startswith("not completed (bench lost)")
    assert "FAILED" not in stated.self_check + " ".join(stated.failed_checks)
    assert stated.overall == NOT_STATED and stated.model_text.startswith(NOT_STATED)
    for raised in ({"outcome": "error", "checks": []},
                   {"outcome": "failed", "checks": None, "message": "CaptureIntegrityError: x"}):
        stated = overall_statement(record(self_check_entry(True) | raised,
                                          measured("a", "baseline", "pass")), [])
        assert stated.self_check.startswith("not completed:") and stated.overall == NOT_STATED
        assert "FAILED" not in stated.reason and stated.model_text.startswith(NOT_STATED)


def test_a_run_that_judged_nothing_is_not_stated():
    diagnosis = {"test_id": "d", "source": "diagnosis", "kind": "diagnosis", "outcome": MEASURED}
    cell = {"test_id": "m", "source": "ripple_map", "kind": "ripple_map", "outcome": MEASURED}
    # a record written before the outcome existed: passed, measured, judged by nothing
    old_cell = cell | {"outcome": "passed", "measured": {"pk_pk_pu": 0.01}}
    for tests in ((diagnosis,), (cell,), (old_cell,), (self_check_entry(True),)):
        stated = overall_statement(record(*tests), [])
        assert stated.overall == NOT_STATED and "nothing was judged" in stated.reason


def test_requirements_applied_to_no_point_are_not_stated_overall():
    given = {"lines": [{"id": "REQ-7"}]}
    stated = overall_statement(record(measured("a", "baseline", "pass"), requirements=given), [])
    assert stated.requirements.startswith(NOT_STATED)
    assert stated.overall == NOT_STATED and "applied to no measured point" in stated.reason
    lines = summary_lines(record(measured("a", "baseline", "pass"), requirements=given))
    assert "requirements: 1 given, 0 judged, 0 verdicts; NOT STATED, judged no point: REQ-7" \
        in lines
    stated = overall_statement(record(measured("a", "baseline", "pass")), [])
    assert stated.requirements == "no requirements given" and stated.overall == PASS


def test_a_non_strict_xpass_is_not_a_failure():
    xpass = {"test_id": "x", "source": "baseline", "outcome": "xpassed"}
    stated = overall_statement(record(measured("a", "baseline", "pass"), xpass), [])
    assert stated.overall == PASS and stated.bad_tests == []


def test_summary_counts_a_test_that_failed_its_requirement_as_failed():
    failing = measured("a", "baseline", "pass", outcome="failed",
                       requirements=[requirement_verdict("REQ-90", 5.0, 1.0)])
    lines = summary_lines(record(self_check_entry(True), failing))
    row = next(line for line in lines if line.startswith("baseline")).split()
    assert row[1:7] == ["1", "0", "0", "0", "1", "0"]        # pts, pass, c.pass, c.fail, fail, err
    assert any("not accepted: REQ-90" in line for line in lines)


def test_summary_never_says_all_pass_where_statement_1_is_not_stated():
    """Every recorded verdict accepted but the run interrupted: statement 1 is NOT STATED, and
    the summary printed as the run ends says so instead of "all pass"."""
    tests = (measured("a", "baseline", "pass",
                      requirements=[requirement_verdict("REQ-1", 2.0, 30.0)]),
             {"test_id": "b", "source": "baseline", "outcome": "not run"})
    interrupted = record(*tests, status="interrupted")
    assert overall_statement(interrupted, None).requirements.startswith(NOT_STATED)
    text = "\n".join(summary_lines(interrupted))
    assert "all pass" not in text
    assert "requirements: 1 verdicts, all accepted; statement: NOT STATED (run interrupted)" \
        in text
    assert "requirements: 1 verdicts, all pass" in "\n".join(summary_lines(record(*tests[:1])))


def test_a_model_verdict_inside_the_guard_band_that_failed_its_test_is_a_fail():
    """-700 rpm / 12 A: the encoder plan's point 25 was a guarded 'conditional pass', its test
    failed (PointOutcome.passed needs guarded_pass), the summary counted it 'fail', yet statement
    2 said 'encoder: CONDITIONAL PASS'. One word everywhere: FAIL, with the test as reason."""
    inside = measured("enc25", "encoder", "conditional pass", outcome="failed") | {
        "verdict": {"decision": "conditional pass", "guarded_pass": False},
        "message": "conditional pass: pk-pk 0.01077 pu ± 0.0024, zone [0.0049, 0.0124]"}
    stated = overall_statement(record(self_check_entry(True),
                                      measured("enc5", "encoder", "pass"), inside), [])
    assert stated.model_text == "encoder: FAIL (1 pass, 1 fail)"
    assert any("enc25" in reason and "conditional pass" in reason
               for reason in stated.sources["encoder"].reasons)
    assert stated.overall == "FAIL"
    # a plan that accepts such a point (its test passed) keeps the non-binary word
    accepted = inside | {"outcome": "passed"}
    stated = overall_statement(record(self_check_entry(True), accepted), [])
    assert stated.model_text == "encoder: CONDITIONAL PASS (1 conditional pass)"
    # a test failed by something else (a requirement) leaves a model pass a pass
    other = measured("b", "baseline", "pass", outcome="failed",
                     requirements=[requirement_verdict("REQ-1", 29.99, 30.0)])
    assert overall_statement(record(self_check_entry(True), other), []).model_text == \
        "baseline: PASS"
