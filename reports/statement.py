"""What a run may state (design.md §7): four statements kept apart, and the overall one.

1. **requirements conformity** — the user's own limits: PASS, FAIL naming the requirement ids,
   NOT STATED (run incomplete, bench self-check failed, a value inside the guard band) or
   "no requirements given";
2. **model validation** — measured vs the paper's (or a derived) prediction, per source;
3. **bench self-check** — PASS, FAILED (naming the checks), "not completed" (it did not run to
   its end, e.g. the bench was lost) or "not run";
4. **run status and integrity** — the record's status and whether every hash verifies.

A failed or not completed self-check voids the requirement and model-validation statements
(design.md §7): both read NOT STATED. Overall, from worst to best: INVALID (a hash does not
verify) > NOT STATED (the run did not finish every selected test, the self-check failed or did
not complete, requirements were given but judged no point, or nothing at all was judged) > FAIL
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
    #: Why the requirement and model statements are void ("" when they stand).
    voided: str = ""

    @property
    def model_text(self) -> str:
        """Statement 2 as page 1 and the summary print it."""
        if self.voided:
            return f"{NOT_STATED} ({self.voided})"
        return "; ".join(f"{source}: {decision.upper()}" for source, decision
                         in self.model.items()) or "no model verdict recorded"


def accepted(verdict: dict) -> bool:
    """A requirement verdict meets its limit under its rule."""
    if "accepted" in verdict:
        return bool(verdict["accepted"])
    decision = verdict.get("decision")
    return decision == "pass" or (verdict.get("rule") == "simple"
                                  and decision == "conditional pass")


def self_check_statement(record: dict) -> tuple[str, list[str], str]:
    """``(statement 3, what failed or did not complete, void reason or "")``.

    FAILED only when a check ran and failed (or the self-check test failed after its checks ran
    and passed); a self-check that stopped before its checks were recorded (an exception, an
    error, not run, a lost bench) is "not completed", never FAILED with checks that never ran."""
    tests = record.get("tests", [])
    lost = bool((record.get("run") or {}).get("abort"))
    self_check_tests = [t for t in tests if t.get("kind") == "self_check" or t.get("checks")]
    failed = [f"{c.get('name')} ({t['test_id']})" for t in self_check_tests
              for c in t.get("checks") or [] if not c.get("passed")]
    unfinished = []
    for test in self_check_tests:
        outcome = test.get("outcome")
        if any(not c.get("passed") for c in test.get("checks") or []):
            continue
        detail = test.get("message") or test.get("error")
        if outcome == "failed" and test.get("checks") and not lost:
            failed.append(f"{test['test_id']}: failed ({detail or 'no detail'})")
        elif outcome in ("failed", "error", "not run", None):
            unfinished.append(f"{test['test_id']}: {outcome or 'no outcome'}"
                              + (", bench lost" if lost else "")
                              + (f" ({detail})" if detail else ""))
    if failed:
        return "FAILED: the other verdicts of this run are not stated", failed, \
            "voided by the failed bench self-check"
    if unfinished:
        text = "not completed (bench lost)" if lost else "not completed"
        return f"{text}: the other verdicts of this run are not stated", unfinished, \
            "voided: the bench self-check did not complete"
    if not self_check_tests:
        return "not run", [], ""
    if all(t.get("outcome") == "passed" for t in self_check_tests):
        return PASS, [], ""
    return "not run (" + ", ".join(f"{t['test_id']}: {t.get('outcome')}"
                                   for t in self_check_tests) + ")", [], ""


def overall_statement(record: dict, integrity_problems: list[str] | None) -> Statement:
    """The four statements of a record and the overall one (``integrity_problems`` None: the
    hashes were not checked, e.g. the summary printed as the run ends)."""
    tests = record.get("tests", [])
    status = record.get("status")
    complete = status == "complete"
    bad = [t["test_id"] for t in tests if t.get("outcome") in BAD_OUTCOMES]
    self_check, failed_checks, voided = self_check_statement(record)

    verdicts = [r for t in tests for r in t.get("requirements") or []]
    failed_req = sorted({r["id"] for r in verdicts
                         if not accepted(r) and r.get("decision") in ("fail", "conditional fail")})
    guard = sorted({r["id"] for r in verdicts if not accepted(r)} - set(failed_req))
    demonstration = sorted({r["id"] for r in verdicts if r.get("demonstration")})
    listed = (record.get("requirements") or {}).get("lines") or []
    unjudged_requirements = bool(listed) and not verdicts
    if not verdicts and not listed:
        requirements = "no requirements given"
    elif voided:
        requirements = f"{NOT_STATED} ({voided})"
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
                 f"{INVALID}: {len(integrity_problems)} problem(s)" if integrity_problems else
                 "NOT SEALED: the run never finished (no record.sha256); every capture hash "
                 "verifies" if status == "running" else "intact: every hash verifies")

    not_stated = [reason for condition, reason in (
        (not complete, run),
        (bool(voided), "bench self-check " + ("FAILED" if self_check.startswith("FAILED")
                                              else "not completed")),
        (unjudged_requirements, "requirements were given but applied to no measured point"),
        (not verdicts and not model and bool(tests), "nothing was judged: no model or "
                                                     "requirement verdict"),
    ) if condition]
    failing = "; ".join(part for part in (
        f"{len(bad)} test(s) failed or errored" if bad else "",
        f"requirement(s) not met: {', '.join(failed_req)}" if failed_req and not voided
        else "") if part)
    if integrity_problems:
        overall, reason = INVALID, "the record or a capture does not match its hash"
    elif not_stated:
        overall, reason = NOT_STATED, "; ".join(not_stated + ([failing] if failing else []))
    elif failing:
        overall, reason = FAIL, failing
    elif not tests:
        overall, reason = NOT_STATED, "no test was recorded"
    elif guard or any(d != "pass" for d in model.values()):
        overall, reason = CONDITIONAL_PASS, "a value lies inside the guard band"
    else:
        overall, reason = PASS, ""
    return Statement(overall=overall, reason=reason, requirements=requirements,
                     failed_requirements=failed_req, demonstration=demonstration, model=model,
                     self_check=self_check, failed_checks=failed_checks, run=run,
                     integrity=integrity, bad_tests=bad, voided=voided)
