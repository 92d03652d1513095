"""What a run may state (design.md §7): four statements kept apart, and the overall one.

1. **requirements conformity** — the user's own limits: PASS, FAIL naming the requirement ids,
   NOT STATED (run incomplete, bench self-check failed, a value inside the guard band) or
   "no requirements given";
2. **model validation** — measured vs the paper's (or a derived) prediction, per source;
3. **bench self-check** — PASS, FAILED (naming the checks) or "not run";
4. **run status and integrity** — the record's status and whether every hash verifies.

Overall, from worst to best: INVALID (a hash does not verify) > NOT STATED (the run did not
finish every selected test, or the bench self-check failed: the other verdicts are void) > FAIL
(a failed or errored test, a requirement not met) > CONDITIONAL PASS > PASS. Never PASS with a
failed or errored test, an incomplete run or a broken hash.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from hil.record import BAD_OUTCOMES

PASS, CONDITIONAL_PASS, FAIL, NOT_STATED, INVALID = (
    "PASS", "CONDITIONAL PASS", "FAIL", "NOT STATED", "INVALID")
DECISIONS = ("pass", "conditional pass", "conditional fail", "fail")
#: Record statuses and what they mean for a reader.
STATUS_TEXT = {
    "complete": "complete: every selected test ran to its end on a live bench",
    "running": "never finished: the process stopped before it could close the record",
    "interrupted": "interrupted (Ctrl-C)",
    "aborted": "aborted: the bench was lost",
    "stopped": "stopped early by pytest (-x / --maxfail)",
    "partial-selection": "partial selection: some collected points were deselected",
    "failed": "the test session itself failed (internal error)",
}


@dataclass
class Statement:
    overall: str
    reason: str
    requirements: str
    failed_requirements: list[str] = field(default_factory=list)
    demonstration: list[str] = field(default_factory=list)
    model: dict[str, str] = field(default_factory=dict)
    self_check: str = "not run"
    failed_checks: list[str] = field(default_factory=list)
    run: str = ""
    integrity: str = "not checked"
    bad_tests: list[str] = field(default_factory=list)


def accepted(verdict: dict) -> bool:
    """A requirement verdict meets its limit under its rule."""
    if "accepted" in verdict:
        return bool(verdict["accepted"])
    decision = verdict.get("decision")
    return decision == "pass" or (verdict.get("rule") == "simple"
                                  and decision == "conditional pass")


def overall_statement(record: dict, integrity_problems: list[str] | None) -> Statement:
    """The four statements of a record and the overall one (``integrity_problems`` None: the
    hashes were not checked, e.g. the summary printed as the run ends)."""
    tests = record.get("tests", [])
    status = record.get("status")
    complete = status == "complete"
    bad = [t["test_id"] for t in tests if t.get("outcome") in BAD_OUTCOMES]

    checks = [c | {"test_id": t["test_id"]} for t in tests for c in t.get("checks") or []]
    self_check_tests = [t for t in tests if t.get("kind") == "self_check" or t.get("checks")]
    failed_checks = [f"{c.get('name')} ({c['test_id']})" for c in checks if not c.get("passed")]
    failed_checks += [f"{t['test_id']}: {t.get('outcome')}" for t in self_check_tests
                      if t.get("outcome") in BAD_OUTCOMES and not any(
                          not c.get("passed") for c in t.get("checks") or [])]
    if failed_checks:
        self_check = "FAILED: the other verdicts of this run are not stated"
    elif self_check_tests:
        ran = [t for t in self_check_tests if t.get("outcome") == "passed"]
        self_check = PASS if len(ran) == len(self_check_tests) else "not run to its end"
    else:
        self_check = "not run"

    verdicts = [r for t in tests for r in t.get("requirements") or []]
    failed_req = sorted({r["id"] for r in verdicts
                         if not accepted(r) and r.get("decision") in ("fail", "conditional fail")})
    guard = sorted({r["id"] for r in verdicts if not accepted(r)} - set(failed_req))
    demonstration = sorted({r["id"] for r in verdicts if r.get("demonstration")})
    listed = (record.get("requirements") or {}).get("lines") or []
    if not verdicts and not listed:
        requirements = "no requirements given"
    elif failed_checks:
        requirements = f"{NOT_STATED} (bench self-check FAILED)"
    elif failed_req:
        requirements = f"{FAIL}: {', '.join(failed_req)}" + ("" if complete else
                                                              f" (run {status})")
    elif not complete:
        requirements = f"{NOT_STATED} (run {status})"
    elif guard:
        requirements = f"{NOT_STATED}: inside the guard band: {', '.join(guard)}"
    elif not verdicts:
        requirements = f"{NOT_STATED}: no measured point was judged against a requirement"
    else:
        requirements = PASS

    model: dict[str, str] = {}
    for test in tests:
        decision = (test.get("verdict") or {}).get("decision")
        source = test.get("source") or "other"
        if decision in DECISIONS:
            previous = model.get(source)
            if previous is None or DECISIONS.index(decision) > DECISIONS.index(previous):
                model[source] = decision

    run = STATUS_TEXT.get(status, f"status {status!r}")
    integrity = ("not checked" if integrity_problems is None else
                 "intact: every hash verifies" if not integrity_problems else
                 f"{INVALID}: {len(integrity_problems)} problem(s)")

    if integrity_problems:
        overall, reason = INVALID, "the record or a capture does not match its hash"
    elif not complete:
        overall, reason = NOT_STATED, run
    elif failed_checks:
        overall, reason = NOT_STATED, "bench self-check FAILED"
    elif bad or failed_req:
        overall = FAIL
        reason = "; ".join(part for part in (
            f"{len(bad)} test(s) failed or errored" if bad else "",
            f"requirement(s) not met: {', '.join(failed_req)}" if failed_req else "") if part)
    elif not tests:
        overall, reason = NOT_STATED, "no test was recorded"
    elif guard or any(d != "pass" for d in model.values()):
        overall, reason = CONDITIONAL_PASS, "a value lies inside the guard band"
    else:
        overall, reason = PASS, ""
    return Statement(overall=overall, reason=reason, requirements=requirements,
                     failed_requirements=failed_req, demonstration=demonstration, model=model,
                     self_check=self_check, failed_checks=failed_checks, run=run,
                     integrity=integrity, bad_tests=bad)
