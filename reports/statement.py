"""What a run may state (design.md §7): four statements kept apart, and the overall one.

**One derivation.** :func:`source_states` is a plain fold over the record's tests that gives each
source its state (pass / conditional pass / not determined / not run / measured, no verdict /
conditional fail / fail) with counts and reasons; :func:`overall_statement` builds every statement
from it. Page 1, the source pages (``reports.content``) and the terminal summary
(``fixtures.summary``) call these two functions and re-derive nothing.

1. **requirements conformity** — the user's own limits, each under its own decision rule: PASS,
   FAIL naming every requirement its rule did not accept (with the ILAC-G8 zone when the value
   was within U of the limit), NOT STATED (run incomplete, bench self-check failed or not
   completed, or a requirement given that applied to no measured point: "N given, M judged") or
   "no requirements given";
2. **model validation** — per selected source, its worst state over *every* test of it: a point
   not run, skipped, errored or not determinable here makes the source NOT DETERMINED (never PASS
   on the points that did run); a failed point or a rejected sweep check makes it FAIL;
   diagnosis / ripple-map points judge nothing (MEASURED, NO VERDICT) or are judged by
   requirements only (NO MODEL VERDICT: statement 1 states them) and move no state;
3. **bench self-check** — PASS, FAILED (naming the checks), "not completed" (it did not run to
   its end, e.g. the bench was lost) or "not run";
4. **run status and integrity** — the record's status (with the signal that stopped it, when
   recorded) and whether every hash verifies.

A failed or not completed self-check voids the requirement and model-validation statements
(design.md §7): both read NOT STATED. Overall, from worst to best: INVALID (a hash does not
verify) > NOT STATED when voided by the self-check > FAIL (a failed or errored test, a requirement
not met — in any run status: a failure that happened is stated, with "the rest is not stated"
when the run did not finish) > NOT STATED (the run did not finish every selected test, a source
not determined, a requirement given that judged no point, or nothing at all judged) >
CONDITIONAL PASS > PASS. Never PASS with a failed or errored test, an incomplete run, a source not
determined or a broken hash. A test stopped by a lost bench (:func:`lost_with_bench`) failed on
the link, not on the drive: it is not determined, never a FAIL of its plan or of the run (the
run reads NOT STATED, aborted). A PASS names what it covers, e.g. "PASS (model validation and
self-check; no requirements given)".

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
model-validation verdicts inside their guard band whose plan accepted them (the test passed); one
that failed its test (the standard plans require a guarded pass) is a fail of statement 2 too.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

from hil.outcome_kinds import MEASURED, NOT_DETERMINABLE, is_not_determinable
from hil.record import BAD_OUTCOMES

PASS, CONDITIONAL_PASS, FAIL, NOT_STATED, INVALID = (
    "PASS", "CONDITIONAL PASS", "FAIL", "NOT STATED", "INVALID")
DECISIONS = ("pass", "conditional pass", "conditional fail", "fail")
#: A source's states. ``STATE_RANK`` orders the judged ones best to worst (a source's state is
#: the worst of its tests); "not run" and "measured, no verdict" are what a source is when none
#: of its tests ran, or none judged anything.
NOT_DETERMINED, NOT_RUN = "not determined", "not run"
#: A test judged by requirements only (no model, no self-check): it has no part in statement 2.
NO_MODEL_VERDICT = "no model verdict"
STATE_RANK = ("pass", "conditional pass", NOT_DETERMINED, "conditional fail", "fail")
#: Record statuses and what they mean for a reader.
STATUS_TEXT = {
    "complete": "complete: every selected test ran to its end on a live bench",
    "running": "never finished: the process stopped before it could close the record",
    "interrupted": "interrupted (Ctrl-C)",
    "terminated": "terminated (SIGTERM): the process was asked to stop; the bench was left safe",
    "aborted": "aborted: the bench was lost",
    "stopped": "stopped early by pytest (-x / --maxfail)",
    "partial-selection": "partial selection: some collected points were deselected",
    "failed": "the test session itself failed (internal error)",
    "storage-error": "stopped: the record could not be written (the run section's storage_error "
                     "names the file and errno)",
}


def run_status_text(record: dict) -> str:
    """Statement 4's run part: the status's meaning, and for an interrupted run the signal the
    record's ``interruption`` section names (``fixtures.session``): "interrupted (Ctrl-C)" only
    for SIGINT or when no signal is recorded."""
    status = record.get("status")
    interruption = record.get("interruption")
    signal = interruption.get("signal") if isinstance(interruption, dict) else None
    if status in ("interrupted", "terminated") and signal not in (None, "SIGINT"):
        return (STATUS_TEXT["terminated"] if signal == "SIGTERM" else
                f"interrupted by {signal}: the bench was left safe")
    return STATUS_TEXT.get(status, f"status {status!r}")


def source_of(entry: dict) -> str:
    """The ripple source a test belongs to: its ``source`` field, else its prediction's, else
    its test-plan module (``test_encoder.py`` → ``encoder``)."""
    if entry.get("source"):
        return str(entry["source"])
    if (entry.get("prediction") or {}).get("source"):
        return str(entry["prediction"]["source"])
    nodeid = entry.get("nodeid") or entry.get("test_id") or ""
    module = Path(str(nodeid).split("::")[0]).stem
    return module.removeprefix("test_") or "other"


def lost_with_bench(record: dict, test: dict) -> bool:
    """The test during which the bench was lost or the record could not be written
    (``run.abort`` / ``run.storage_error``: their ``step`` names it; the plugin's message
    starts "bench lost" / "record storage failed"): it stopped on the link or the disk, not on
    the drive, so it judged nothing — not determined, never a fail of its plan or of the run."""
    if test.get("outcome") not in ("failed", "error"):
        return False
    run = record.get("run") or {}
    for fault, message in ((run.get("abort"), "bench lost"),
                           (run.get("storage_error"), "record storage failed")):
        if isinstance(fault, dict) and (
                str(fault.get("step") or "").startswith(f"{test.get('test_id')} (")
                or str(test.get("message") or "").startswith(message)):
            return True
    return False


def test_state(test: dict) -> str | None:
    """One test's part in its source's state: a decision of :data:`STATE_RANK`, "not run",
    :data:`MEASURED` (judged nothing), :data:`NO_MODEL_VERDICT` (judged by requirements only),
    or None (no part: an expected failure or a non-strict unexpected pass, as pytest counts
    them)."""
    outcome = test.get("outcome")
    decision = (test.get("verdict") or {}).get("decision")
    if outcome == NOT_RUN:
        return NOT_RUN
    if outcome in ("skipped", "error", NOT_DETERMINABLE):
        return NOT_DETERMINED
    if outcome == MEASURED:
        return MEASURED
    if outcome in ("xfailed", "xpassed"):
        return None
    if decision in DECISIONS:
        # a model verdict inside the guard band (guarded rule: not accepted) whose test failed
        # on it is a fail of that rule, as the summary table, pytest and the exit status say
        # (one word everywhere, as for requirements); CONDITIONAL PASS stays for a plan that
        # accepts such a point
        if decision == "conditional pass" and outcome == "failed" \
                and (test.get("verdict") or {}).get("guarded_pass") is False:
            return "fail"
        return decision
    if outcome in ("passed", "failed") and test.get("requirements") and not test.get("checks") \
            and (outcome == "passed" or not all(map(accepted, test["requirements"]))):
        return NO_MODEL_VERDICT     # judged by requirements only: statement 1, not statement 2
    if outcome == "passed" and test.get("measured") and not test.get("checks"):
        return MEASURED      # measure() judged nothing (a record written before the outcome)
    return "fail" if outcome == "failed" else "pass" if outcome == "passed" else NOT_DETERMINED


#: The words tests are counted in, in this order: the record's outcomes. pytest's own line
#: uses the same words (``fixtures.plugin``'s ``pytest_report_teststatus`` names the two
#: ripple-hil adds), so the summary, page 1 and pytest give one count.
OUTCOME_ORDER = ("passed", "failed", "error", "skipped", NOT_DETERMINABLE, MEASURED, "xfailed",
                 "xpassed", NOT_RUN)


def is_test(entry: dict) -> bool:
    """A pytest test's own entry (a measurement a test makes beside its own, e.g. the
    self-check's ``<nodeid>-reference``, is part of that test, not a test)."""
    return entry.get("nodeid") in (None, entry.get("test_id"))


def outcome_counts(record: dict) -> dict[str, int]:
    """Each test of the record counted once by its recorded outcome (:data:`OUTCOME_ORDER`,
    zeros left out)."""
    counts = Counter(str(t.get("outcome")) for t in record.get("tests", []) if is_test(t))
    order = {name: i for i, name in enumerate(OUTCOME_ORDER)}
    return {name: counts[name] for name in sorted(counts, key=lambda n: order.get(n, len(order)))}


def counts_text(counts: dict[str, int]) -> str:
    """``38 passed, 29 measured, no verdict``."""
    return ", ".join(f"{n} {name}" for name, n in counts.items() if n) or "none recorded"


@dataclass
class SourceState:
    """A source's state over every one of its tests, with the counts and the reasons it is not
    a plain pass (each "test id: outcome: message")."""

    name: str
    state: str
    counts: dict = field(default_factory=dict)
    reasons: list[str] = field(default_factory=list)

    @property
    def text(self) -> str:
        """``encoder: NOT DETERMINED (3 pass, 2 not run)``; a source whose every test passed:
        ``encoder: PASS``."""
        order = (*STATE_RANK, NOT_RUN, NO_MODEL_VERDICT, MEASURED)
        counts = ", ".join(f"{self.counts[state]} {state}" for state in sorted(
            self.counts, key=lambda s: order.index(s) if s in order else len(order))
            if self.counts[state]) if set(self.counts) - {"pass"} else ""
        return f"{self.name}: {self.state.upper()}" + (f" ({counts})" if counts else "")


def reason_line(test: dict) -> str:
    """``test: outcome: message`` (a not-determinable message already says so)."""
    detail = test.get("message") or test.get("error") or ""
    name = str(test.get("test_id")).split("::")[-1]
    if is_not_determinable(detail):
        return f"{name}: {detail}"
    return f"{name}: {test.get('outcome')}" + (f": {detail}" if detail else "")


def source_states(record: dict) -> dict[str, SourceState]:
    """Every source of the record's tests (the bench self-check excepted: statement 3) → its
    state: the worst of its tests' states (:data:`STATE_RANK`; "not run" counts as not
    determined beside tests that ran), FAIL when a check across its sweep rejected the drive;
    "not run" when none of its tests ran; "measured, no verdict" when those that ran judged
    nothing."""
    states: dict[str, list[tuple[str, dict]]] = {}
    for test in record.get("tests", []):
        if test.get("kind") == "self_check":
            continue
        state = NOT_DETERMINED if lost_with_bench(record, test) else test_state(test)
        states.setdefault(source_of(test), [])
        if state is not None:
            states[source_of(test)].append((state, test))
    out = {}
    for source, items in states.items():
        counts = Counter(state for state, _ in items)
        judged = [NOT_DETERMINED if state == NOT_RUN else state for state, _ in items
                  if state not in (MEASURED, NO_MODEL_VERDICT)]
        if rejected_checks(record, source):
            judged.append("fail")
        if not items:
            state = "pass"               # only expected failures / unexpected passes
        elif judged and not all(s == NOT_RUN for s, _ in items):
            state = max(judged, key=STATE_RANK.index)
        elif judged:
            state = NOT_RUN
        else:
            state = NO_MODEL_VERDICT if counts[NO_MODEL_VERDICT] else MEASURED
        reasons = [reason_line(test) for s, test in items if s in (NOT_DETERMINED, NOT_RUN, "fail")]
        reasons += [f"{name} check across the sweep rejected the drive"
                    for name in rejected_checks(record, source)]
        out[source] = SourceState(source, state, dict(counts), reasons)
    return out


@dataclass
class Statement:
    overall: str
    reason: str
    requirements: str
    failed_requirements: list[str] = field(default_factory=list)
    demonstration: list[str] = field(default_factory=list)
    #: source → its state (``sources[name].state``), kept for callers that want the word only
    model: dict[str, str] = field(default_factory=dict)
    self_check: str = "not run"
    failed_checks: list[str] = field(default_factory=list)
    run: str = ""
    integrity: str = "not checked"
    bad_tests: list[str] = field(default_factory=list)
    #: Why the requirement and model statements are void ("" when they stand).
    voided: str = ""
    sources: dict[str, SourceState] = field(default_factory=dict)
    #: Requirement lines given for the run, and how many of them judged at least one point.
    requirements_given: int = 0
    requirements_judged: int = 0
    #: Requirement ids given that applied to no measured point.
    unjudged_requirements: list[str] = field(default_factory=list)
    #: Tests by recorded outcome (:func:`outcome_counts`): the one count of every sink.
    counts: dict[str, int] = field(default_factory=dict)
    #: Tests that judged the drive (a model decision or a requirement verdict); 0: the run
    #: judged nothing and ``hil run`` exits :data:`hil.record.EXIT_NOTHING_JUDGED`.
    judged: int = 0

    @property
    def model_text(self) -> str:
        """Statement 2 as page 1 and the summary print it: every selected source with its
        state and counts."""
        if self.voided:
            return f"{NOT_STATED} ({self.voided})"
        return "; ".join(state.text for state in self.sources.values()) \
            or "no model verdict recorded"


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


def requirement_statement(record: dict, verdicts: list[dict], voided: str,
                          complete: bool) -> tuple[str, list[str], list[str]]:
    """``(statement 1, ids not accepted, ids given that judged no point)``."""
    rejected = rejected_requirements(verdicts)
    failed = sorted(rejected)
    listed = [str(line.get("id")) for line in
              (record.get("requirements") or {}).get("lines") or []]
    judged = {str(v.get("id")) for v in verdicts}
    unjudged = [rid for rid in listed if rid not in judged]
    status = record.get("status")
    if not verdicts and not listed:
        return "no requirements given", failed, unjudged
    if voided:
        return f"{NOT_STATED} ({voided})", failed, unjudged
    if failed:
        return (f"{FAIL}: " + ", ".join(
            rid + (f" ({ZONE_TEXT[rejected[rid]]})" if rejected[rid] in ZONE_TEXT else "")
            for rid in failed) + ("" if complete else f" (run {status})")
            + (f"; applied to no measured point: {', '.join(unjudged)}" if unjudged else ""),
            failed, unjudged)
    if not complete:
        return f"{NOT_STATED} (run {status})", failed, unjudged
    if unjudged:
        return (f"{NOT_STATED}: applied to no measured point: {', '.join(unjudged)} "
                f"({len(listed)} given, {len(listed) - len(unjudged)} judged)"), failed, unjudged
    return PASS, failed, unjudged


def overall_statement(record: dict, integrity_problems: list[str] | None) -> Statement:
    """The four statements of a record and the overall one (``integrity_problems`` None: the
    hashes were not checked, e.g. the summary printed as the run ends)."""
    tests = record.get("tests", [])
    status = record.get("status")
    complete = status == "complete"
    bad = [t["test_id"] for t in tests
           if t.get("outcome") in BAD_OUTCOMES and not lost_with_bench(record, t)]
    self_check, failed_checks, voided = self_check_statement(record)

    verdicts = [r for t in tests for r in t.get("requirements") or []]
    requirements, failed_req, unjudged = requirement_statement(record, verdicts, voided,
                                                               complete)
    listed = (record.get("requirements") or {}).get("lines") or []
    demonstration = sorted({r["id"] for r in verdicts if r.get("demonstration")})
    sources = source_states(record)
    model = {name: state.state for name, state in sources.items()}
    run = run_status_text(record)
    integrity = ("not checked" if integrity_problems is None else
                 f"{INVALID}: {len(integrity_problems)} problem(s)" if integrity_problems else
                 "NOT SEALED: the run never finished (no record.sha256); every capture hash "
                 "verifies" if status == "running" else "intact: every hash verifies")

    judged_states = [s for s in model.values() if s in STATE_RANK]
    undetermined = [name for name, s in model.items() if s in (NOT_DETERMINED, NOT_RUN)]
    not_stated = [reason for condition, reason in (
        (not complete, run),
        (bool(undetermined) and complete, "not determined: " + ", ".join(undetermined)),
        (bool(unjudged), f"requirement(s) applied to no measured point: {', '.join(unjudged)}"),
        (not verdicts and not judged_states and bool(tests),
         "nothing was judged: no model or requirement verdict"),
    ) if condition]
    failing = "; ".join(part for part in (
        f"{len(bad)} test(s) failed or errored" if bad else "",
        f"requirement(s) not met: {', '.join(failed_req)}" if failed_req and not voided
        else "") if part)
    if integrity_problems:
        overall, reason = INVALID, "the record or a capture does not match its hash"
    elif voided:
        overall = NOT_STATED
        reason = "; ".join(["bench self-check " + ("FAILED" if self_check.startswith("FAILED")
                                                   else "not completed")]
                           + ([run] if not complete else []) + ([failing] if failing else []))
    elif failing:
        overall, reason = FAIL, failing + (
            f"; the rest is not stated ({'; '.join(not_stated)})" if not_stated else "")
    elif not_stated:
        overall, reason = NOT_STATED, "; ".join(not_stated)
    elif not tests:
        overall, reason = NOT_STATED, "no test was recorded"
    elif any(s == "conditional pass" for s in model.values()):
        overall, reason = CONDITIONAL_PASS, "model verdict(s) inside the guard band: " + \
            ", ".join(sorted(name for name, s in model.items() if s == "conditional pass"))
    else:
        overall, reason = PASS, _scope(verdicts, judged_states, self_check)
    return Statement(overall=overall, reason=reason, requirements=requirements,
                     failed_requirements=failed_req, demonstration=demonstration, model=model,
                     self_check=self_check, failed_checks=failed_checks, run=run,
                     integrity=integrity, bad_tests=bad, voided=voided, sources=sources,
                     requirements_given=len(listed),
                     requirements_judged=len(listed) - len(unjudged),
                     unjudged_requirements=unjudged, counts=outcome_counts(record),
                     judged=judged_tests(record))


def judged_tests(record: dict) -> int:
    """How many tests judged the drive: a model decision of :data:`STATE_RANK` (or a test
    failed on its model), or a requirement verdict; the bench self-check, points measured with
    no verdict, points not determinable, not run or lost with the bench judge nothing."""
    judged = 0
    for test in record.get("tests", []):
        if test.get("kind") == "self_check" or lost_with_bench(record, test):
            continue
        decision = (test.get("verdict") or {}).get("decision")
        if test.get("requirements") or decision in DECISIONS:
            judged += 1
        elif not test.get("checks") and test_state(test) in ("pass", "fail"):
            judged += 1                # a plain test's own assertions (no measure())
    checks = list(((record.get("sensitivity") or {}) if isinstance(record.get("sensitivity"),
                                                                     dict) else {}).values())
    checks += [check for source in {source_of(t) for t in record.get("tests", [])}
               for _, check in plan_checks(record, source)]
    return judged + sum(isinstance(c, dict) and "accepted" in c for c in checks)


def _scope(verdicts: list, judged_states: list, self_check: str) -> str:
    """What a PASS covers: "model validation and self-check; no requirements given"."""
    parts = [name for name, present in (("requirements", bool(verdicts)),
                                        ("model validation", bool(judged_states)),
                                        ("self-check", self_check == PASS)) if present]
    text = " and ".join(parts) if len(parts) < 3 else f"{parts[0]}, {parts[1]} and {parts[2]}"
    if self_check != PASS:
        text += "; no bench self-check run"
    return text + ("" if verdicts else "; no requirements given")
