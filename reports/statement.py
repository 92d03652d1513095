"""What a run may state (design.md §7): four statements kept apart, and the overall one.

1. **requirements conformity** — the user's own limits, each under its own decision rule: PASS,
   FAIL naming every requirement its rule did not accept (with the ILAC-G8 zone when the value
   was within U of the limit), NOT STATED (run incomplete, bench self-check failed or not
   completed, requirements given but applied to no point) or "no requirements given";
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

A requirement's statement is the binary statement of its decision rule: under guarded
acceptance (the default, guard band w = U; ILAC-G8:09/2019 §4.2.2, "binary statement with guard
band") only a value inside the limit by at least U is a Pass; a value inside the limit by less
than U — the zone the non-binary statement of §4.2.3 calls "conditional pass" — is a Fail
("rejection based on guard band"), and statement 1 says FAIL,
naming the requirement "inside the guard band: within the limit by less than U, not accepted by
the guarded rule". The overall is then FAIL too, as is the pytest outcome of the point's test
(``PointOutcome.passed`` requires every requirement accepted) and ``hil run``'s exit status: one
word everywhere. It is neither CONDITIONAL PASS (the user chose the rule that does not accept
it) nor NOT STATED (kept for runs that could state nothing: incomplete, voided, nothing judged).
Under the simple rule the same value is accepted: PASS. A value beyond the limit by less than U
("conditional fail") is accepted by neither rule: FAIL. CONDITIONAL PASS overall comes only from
model-validation verdicts inside their guard band.
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


def plan_checks(record: dict, source: str) -> list[tuple[str, dict]]:
    """A plan's own checks across its points, recorded as sections named ``<source>_<check>``
    with a ``statement`` and ``accepted`` (e.g. ``pwm_resolution_noise``)."""
    prefix = f"{source}_"
    return [(name[len(prefix):], value) for name, value in sorted(record.items())
            if name.startswith(prefix) and isinstance(value, dict) and "statement" in value]


def rejected_checks(record: dict, source: str) -> list[str]:
    """The source's checks across its sweep that did not accept the drive: its sensitivity
    check (``testplans/sensitivity.py``) and its plan checks. Such a check has no point verdict
    of its own, yet it judges the same model, so the source's model statement is FAIL."""
    checks = [("sensitivity", (record.get("sensitivity") or {}).get(source))]
    checks += plan_checks(record, source)
    return [name for name, check in checks
            if isinstance(check, dict) and check.get("accepted") is False]


#: A requirement its rule did not accept, by ILAC-G8 zone, when the value was within U of the
#: limit (a plain "fail" needs no words).
ZONE_TEXT = {
    "conditional pass": "inside the guard band: within the limit by less than U, not accepted "
                        "by the guarded rule",
    "conditional fail": "beyond the limit by less than U",
}


def rejected_requirements(verdicts: list[dict]) -> dict[str, str]:
    """Requirement id → the worst ILAC-G8 zone among its verdicts that its rule did not accept."""
    rejected: dict[str, str] = {}
    for verdict in verdicts:
        if accepted(verdict):
            continue
        zone = verdict.get("decision") if verdict.get("decision") in DECISIONS else "fail"
        previous = rejected.get(verdict["id"])
        if previous is None or DECISIONS.index(zone) > DECISIONS.index(previous):
            rejected[verdict["id"]] = zone
    return rejected


def overall_statement(record: dict, integrity_problems: list[str] | None) -> Statement:
    """The four statements of a record and the overall one (``integrity_problems`` None: the
    hashes were not checked, e.g. the summary printed as the run ends)."""
    tests = record.get("tests", [])
    status = record.get("status")
    complete = status == "complete"
    bad = [t["test_id"] for t in tests if t.get("outcome") in BAD_OUTCOMES]
    self_check, failed_checks, voided = self_check_statement(record)

    verdicts = [r for t in tests for r in t.get("requirements") or []]
    rejected = rejected_requirements(verdicts)
    failed_req = sorted(rejected)
    demonstration = sorted({r["id"] for r in verdicts if r.get("demonstration")})
    listed = (record.get("requirements") or {}).get("lines") or []
    unjudged_requirements = bool(listed) and not verdicts
    if not verdicts and not listed:
        requirements = "no requirements given"
    elif voided:
        requirements = f"{NOT_STATED} ({voided})"
    elif failed_req:
        requirements = f"{FAIL}: " + ", ".join(
            req_id + (f" ({ZONE_TEXT[rejected[req_id]]})" if rejected[req_id] in ZONE_TEXT
                      else "") for req_id in failed_req) + ("" if complete else
                                                             f" (run {status})")
    elif not complete:
        requirements = f"{NOT_STATED} (run {status})"
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

    for source in list(model):
        if rejected_checks(record, source):
            model[source] = "fail"
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
    elif any(d != "pass" for d in model.values()):
        overall, reason = CONDITIONAL_PASS, "model verdict(s) inside the guard band: " + \
            ", ".join(sorted(source for source, d in model.items() if d != "pass"))
    else:
        overall, reason = PASS, ""
    return Statement(overall=overall, reason=reason, requirements=requirements,
                     failed_requirements=failed_req, demonstration=demonstration, model=model,
                     self_check=self_check, failed_checks=failed_checks, run=run,
                     integrity=integrity, bad_tests=bad, voided=voided)
