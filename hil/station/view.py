"""What the station page shows, from a record (design.md §7, §10): nothing here judges.

* progress per plan: tests recorded so far per source against the points collected for it;
* each verdict as decided: the test's outcome and its recorded model verdict (``verdict``) and
  requirement verdicts, as the run stored them;
* alerts in words an operator understands: a lost bench (the record's ``run.abort`` or a test
  stopped by it) and a failed or unfinished bench self-check, from
  :func:`reports.statement.self_check_statement` — the one derivation page 1 uses;
* at the end, page 1's statements from :func:`reports.statement.overall_statement` with the
  record's integrity from :func:`hil.record.verify_record` (what ``hil report`` passes it);
* operator questions still waiting (``operator_prompts`` section, ``fixtures/operator.py``).
"""

from __future__ import annotations

from pathlib import Path

from hil.record import verify_record
from ripple_hil_reports.statement import overall_statement, self_check_statement

#: What an operator is told for a record status (the words of page 1 are in ``final``).
OPERATOR_STATUS = {
    "running": "measuring",
    "complete": "finished",
    "interrupted": "stopped by the operator (drive made safe)",
    "aborted": "stopped: the bench was lost (drive made safe)",
    "stopped": "stopped early",
    "partial-selection": "finished (part of the plans' points only)",
    "failed": "the test software failed",
}


def short_name(test_id: str) -> str:
    """``testplans/test_dc_offset.py::test_dc_offset[ia=0.01]`` → ``test_dc_offset[ia=0.01]``."""
    return test_id.rsplit("::", 1)[-1]


def progress(record: dict, totals: dict[str, int] | None) -> list[dict]:
    """Per plan (source): pytest items recorded so far, the plan's collected points, and how
    many passed / failed. Counted per pytest item (``nodeid``), as the totals are collected: a
    test that records two entries (the self-check's transducer-dynamics point and its
    reference) is one point, so done never exceeds the total ("self_check 4 / 3", issue 32)."""
    rows: dict[str, dict] = {}
    sources = list((totals or {}).keys()) or \
        list(((record.get("run") or {}).get("selection") or {}).get("sources") or [])
    for source in sources:
        rows[source] = {"source": source, "done": 0, "total": (totals or {}).get(source),
                        "passed": 0, "bad": 0, "not_run": 0}
    items: dict[tuple[str, str], list[str]] = {}
    for test in record.get("tests", []):
        source = test.get("source") or "other"
        key = (source, test.get("nodeid") or test["test_id"])
        items.setdefault(key, []).append(test.get("outcome"))
    for (source, _), outcomes in items.items():
        row = rows.setdefault(source, {"source": source, "done": 0, "total": None,
                                       "passed": 0, "bad": 0, "not_run": 0})
        if all(outcome == "not run" for outcome in outcomes):
            row["not_run"] += 1
            continue
        row["done"] += 1
        row["bad"] += any(outcome in ("failed", "error") for outcome in outcomes)
        row["passed"] += all(outcome == "passed" for outcome in outcomes)
    return list(rows.values())


def verdicts(record: dict) -> list[dict]:
    """Each recorded test's outcome and verdicts, in the order they were decided."""
    out = []
    for index, test in enumerate(record.get("tests", [])):
        verdict = test.get("verdict") or {}
        requirements = [f"{r.get('id')}: {r.get('decision')}"
                        + ("" if r.get("accepted", True) else " (not accepted)")
                        for r in test.get("requirements") or []]
        out.append({"index": index, "test": short_name(test["test_id"]),
                    "source": test.get("source"), "outcome": test.get("outcome"),
                    "decision": verdict.get("decision"),
                    "detail": verdict.get("reason") or test.get("message") or "",
                    "requirements": requirements,
                    "plot": bool(test.get("capture") or (test.get("measured") or {})
                                 .get("sync_average_nm"))})
    return out


def latest_plot_index(record: dict) -> int | None:
    """The last recorded test that has a capture or stored arrays to plot."""
    for index in range(len(record.get("tests", [])) - 1, -1, -1):
        test = record["tests"][index]
        if test.get("capture") or (test.get("measured") or {}).get("sync_average_nm"):
            return index
    return None


def alerts(record: dict) -> list[dict]:
    """A lost bench or a self-check that failed or did not finish, in operator words."""
    out = []
    abort = (record.get("run") or {}).get("abort")
    lost = [t for t in record.get("tests", [])
            if "bench lost" in str(t.get("message") or "")]
    if abort or lost or record.get("status") == "aborted":
        instrument = (abort or {}).get("instrument") or "an instrument"
        out.append({"kind": "bench-lost",
                    "text": f"The bench stopped answering ({instrument}). The drive was "
                            f"switched to its safe state and the run ended. Check the "
                            f"{instrument}'s cable and power, then start the unit again; "
                            f"tell the bench engineer if it happens twice.",
                    "detail": (abort or {}).get("error") or (lost[0].get("message") if lost
                                                             else "")})
    stopped = stopped_by_operator(record)
    if stopped:
        out.append(stopped)
    statement, problems, voided = self_check_statement(record)
    if voided:
        failed = statement.startswith("FAILED")
        out.append({"kind": "self-check",
                    "text": ("The bench self-check FAILED: the bench does not measure what it "
                             "should, so no result of this unit counts. Do not release the "
                             "unit; call the bench engineer." if failed else
                             "The bench self-check did not finish, so no result of this unit "
                             "counts. Start the unit again; call the bench engineer if it "
                             "happens again."),
                    "detail": "; ".join(problems)[:400]})
    return out


def stopped_by_operator(record: dict) -> dict | None:
    """A station run that ended by its Stop (SIGINT from the station; also the station being
    shut down): what was done and what to do next, in operator words."""
    interruption = record.get("interruption") if isinstance(record.get("interruption"),
                                                            dict) else {}
    if record.get("status") != "interrupted" or interruption.get("signal") not in (None,
                                                                                  "SIGINT"):
        return None
    tests = record.get("tests", [])
    done = len({t.get("nodeid") or t["test_id"] for t in tests if t.get("outcome") != "not run"})
    left = len({t.get("nodeid") or t["test_id"] for t in tests
                if t.get("outcome") == "not run"})
    return {"kind": "stopped",
            "text": f"This unit was stopped from the station (Stop) after {done} point(s); "
                    f"{left} point(s) were not run. The drive was switched to its safe state "
                    f"and the measured points are kept in the record, but the unit has no "
                    f"result: do not release it. To test it, scan it and press Start again.",
            "detail": ""}


def banner(statement) -> dict:
    """The final banner: conformity to the customer's requirements, the statement a line
    station is for (design.md §7, statement 1). Without requirements it says so plainly and is
    never a green PASS; the model validation and the self-check stay in the lines below."""
    requirements = statement.requirements
    if requirements == "no requirements given":
        return {"tone": "none", "text": "No requirements were given: conformity of this unit "
                                        "is NOT stated (the station judged no customer limit)."}
    if requirements.startswith("PASS") and statement.overall in ("PASS", "CONDITIONAL PASS"):
        return {"tone": "PASS", "text": f"Conforms to the requirements: {requirements}"}
    if requirements.startswith("FAIL"):
        return {"tone": "FAIL", "text": f"Does NOT conform to the requirements: {requirements}"}
    return {"tone": "NOT STATED", "text": f"Conformity to the requirements not stated: "
                                          f"{requirements}"
                                          + ("" if statement.overall in ("PASS", "FAIL")
                                             else f" (overall {statement.overall})")}


def prompts(record: dict) -> list[dict]:
    """Operator questions asked and not yet answered."""
    asked = (record.get("operator_prompts") or {}).get("prompts") or []
    return [{"key": p["key"], "text": p["text"], "kind": p["kind"], "default": p.get("default")}
            for p in asked if p.get("answered_utc") is None and p.get("by") is None]


def final_statement(record: dict, folder: Path) -> dict:
    """Page 1's statements of a finished record, from the one derivation (reports.statement)."""
    statement = overall_statement(record, verify_record(folder, record))
    return {
        "overall": statement.overall,
        "banner": banner(statement),
        "overall_line": f"Overall: {statement.overall}"
                        + (f" ({statement.reason})" if statement.reason else ""),
        "lines": [
            ["1. Requirements conformity", statement.requirements
             + (f" (demonstration requirement(s): {', '.join(statement.demonstration)})"
                if statement.demonstration else "")],
            ["2. Model validation (vs the paper)", statement.model_text],
            ["3. Bench self-check", statement.self_check
             + (f" ({'; '.join(statement.failed_checks)})" if statement.failed_checks else "")],
            ["4. Run status and integrity",
             ("stopped from the station (Stop): the drive was made safe"
              if stopped_by_operator(record) else statement.run)
             + f"; {statement.integrity}"],
        ],
    }


def unit_of(record: dict) -> str | None:
    """The unit serial number the run recorded (its ``dut`` section, ``hil.dut``; an older
    record's ``unit`` section)."""
    return (record.get("dut") or {}).get("serial") or \
        (record.get("unit") or {}).get("serial_number")


def drive_identity(record: dict) -> str | None:
    """The drive as the record lists it (bench file's model and serial number, and the serial
    the drive itself reported when it differs): shown beside the unit serial the operator gave."""
    row = next((r for r in record.get("instruments") or [] if r.get("role") == "drive"), None)
    if row is None:
        return None
    text = f"{row.get('model') or 'drive'} s/n {row.get('serial_number')}"
    reported = (row.get("identity") or {}).get("serial_number")
    if reported is not None and str(reported) != str(row.get("serial_number")):
        text += f" (the drive reports {reported})"
    return text
