"""What the report says, read from a run record (no PDF here, no analysis re-done).

:func:`report_content` turns ``record.json`` into plain data: the points of each ripple source
(swept parameter, measured and predicted ripple, U, verdict), the statement of conformity per
source and overall, and the deviations to state. Test entries are treated as the test plans wrote
them; a field that is missing shows as "not recorded" instead of failing the report.
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from hil.record import RECORD_FILE
from ripple_hil_reports.revisions import Revision
from hil.outcome_kinds import MEASURED, NOT_DETERMINABLE, is_not_determinable
from ripple_hil_reports.statement import (NOT_DETERMINED, NOT_RUN, SourceState,
                                          Statement, overall_statement, run_status_text,
                                          source_of)

#: ILAC-G8 decisions from best to worst.
DECISIONS = ("pass", "conditional pass", "conditional fail", "fail")
#: A point that records no model verdict (a passed sweep check, a point measured with no
#: verdict): it does not enter its source's statement.
NO_VERDICT = "no model verdict"
#: A source's statement when a failed or unfinished bench self-check voids it (§7).
VOIDED = "not stated"

RIPPLE_DEFINITION = (
    "Torque ripple (per unit) = peak-to-peak of the synchronously averaged torque over whole "
    "electrical revolutions, divided by the mean torque at the operating point (the paper's per "
    "unit of (3/2)·E·I/ω_m). Orders are harmonics of the electrical frequency. The expanded "
    "uncertainty U has a coverage factor k = 2 (about 95 %).")


@dataclass
class Point:
    """One test of a source sweep, as the report prints it (per-unit values of mean torque)."""

    test_id: str
    outcome: str
    x: float | None                 # value of the swept knob, when exactly one knob varies
    label: str                      # the varied knobs' values at the user's edge
    measured_pu: float | None
    u_pu: float | None              # expanded uncertainty of measured_pu, k = 2
    predicted_pu: float | None
    predicted_order: float | None
    lower_pu: float | None          # acceptance limits of the decision rule, when recorded
    upper_pu: float | None
    decision: str
    entry: dict = field(repr=False, default_factory=dict)


@dataclass
class SourceSection:
    name: str
    swept: list[str]                # injection knobs varied across the sweep
    points: list[Point]
    statement: str                  # the source's state (reports.statement.source_states)
    worst: Point | None             # the point with the largest measured ripple
    reasons: list[str] = field(default_factory=list)    # why it is not a plain pass


@dataclass
class ReportContent:
    record: dict
    report_id: str
    partial: bool
    sources: list[SourceSection]
    overall: str                    # the overall statement (reports.statement)
    deviations: list[str]           # real deviations from the method only
    capture_problems: list[str]     # every integrity problem (seal and captures)
    statement: Statement | None = None
    method_notes: list[str] = field(default_factory=list)
    revision: Revision | None = None
    map_cells: list[dict] = field(default_factory=list)
    self_checks: list[dict] = field(default_factory=list)


#: Test kinds with their own report section instead of a source sweep.
OWN_SECTION_KINDS = ("ripple_map", "self_check")


def report_id(record: dict, record_json: bytes, revision: int = 1) -> str:
    """Unique and reproducible: the record id, the first 8 hex digits of record.json's hash and
    the report revision."""
    return (f"RHR-{record['record_id']}-{hashlib.sha256(record_json).hexdigest()[:8]}"
            f"-R{revision}")


def report_content(record: dict, record_dir: Path, capture_problems: list[str],
                   revision: Revision | None = None) -> ReportContent:
    """What the report states; ``capture_problems``: every integrity problem found."""
    record_json = (Path(record_dir) / RECORD_FILE).read_bytes()
    statement = overall_statement(record, capture_problems)
    groups: dict[str, list[dict]] = {}
    own = OWN_SECTION_KINDS + (("diagnosis",) if record.get("diagnosis") else ())
    for entry in record.get("tests", []):
        if entry.get("kind") in own:
            continue
        groups.setdefault(source_of(entry), []).append(entry)
    sources = [_section(name, entries, statement.sources.get(name))
               for name, entries in groups.items()]
    if statement.voided:        # the points' decisions stay listed; the statement is void
        sources = [replace(section, statement=VOIDED) for section in sources]
    revision = revision or Revision(1, None, None, None)
    return ReportContent(record=record, report_id=report_id(record, record_json, revision.number),
                         partial=record.get("status") != "complete", sources=sources,
                         overall=statement.overall,
                         deviations=deviations(record, sources, capture_problems),
                         capture_problems=capture_problems, statement=statement,
                         method_notes=method_notes(record, sources), revision=revision,
                         map_cells=map_cells(record), self_checks=self_checks(record))


def map_cells(record: dict) -> list[dict]:
    """The ripple map's cells: speed, current, pk-pk % of mean and dominant order."""
    cells = []
    for entry in record.get("tests", []):
        if entry.get("kind") != "ripple_map":
            continue
        op, measured = entry.get("operating_point") or {}, entry.get("measured") or {}
        if _number(op.get("speed_rpm")) is None or _number(op.get("current_a")) is None:
            continue
        value = _number(measured.get("pk_pk_pu"))
        cells.append({"speed_rpm": op["speed_rpm"], "current_a": op["current_a"],
                      "pk_pk_pct": None if value is None else 100 * value,
                      "order": measured.get("dominant_order"), "outcome": entry.get("outcome"),
                      "test_id": entry.get("test_id")})
    return cells


def self_checks(record: dict) -> list[dict]:
    """Every self-check of the run (``{test_id, outcome, name, measured, expected, ...}``); a
    self-check test that recorded no check gives one row with ``passed`` None (not completed)."""
    rows = []
    for entry in record.get("tests", []):
        if entry.get("kind") != "self_check" and not entry.get("checks"):
            continue
        for check in entry.get("checks") or [{"name": "(no check recorded)", "passed": None,
                                              "detail": entry.get("message") or
                                              entry.get("error") or entry.get("outcome")}]:
            rows.append({"test_id": entry.get("test_id"), "outcome": entry.get("outcome")}
                        | check)
    return rows


def _section(name: str, entries: list[dict], state: SourceState | None = None
             ) -> SourceSection:
    """One source's points, and its statement as ``reports.statement.source_states`` derived it
    (the one derivation; ``state`` None: derived here from these entries alone)."""
    if state is None:
        from ripple_hil_reports.statement import source_states

        state = source_states({"tests": [e | {"source": name} for e in entries]}).get(name)
    injections = [e.get("injection") or {} for e in entries]
    swept = swept_knobs(injections)
    displays = {k: knob_display(k, [_number(i.get(k)) or 0.0 for i in injections]) for k in swept}
    points = [point_from_entry(e, swept, displays) for e in entries]
    points.sort(key=lambda p: (_sort_key(p.entry.get("injection") or {}, swept), p.test_id))
    measured = [p for p in points if p.measured_pu is not None]
    worst = max(measured, key=lambda p: p.measured_pu) if measured else None
    statement = state.state if state is not None else NOT_RUN
    return SourceSection(name=name, swept=swept, points=points, statement=statement, worst=worst,
                         reasons=list(state.reasons) if state is not None else [])


def swept_knobs(injections: list[dict]) -> list[str]:
    """The injection knobs (numbers or flags) whose values change across the tests, or the
    only knob there is."""
    keys = sorted({k for inj in injections for k, v in inj.items()
                   if isinstance(v, bool) or _number(v) is not None})
    varied = [k for k in keys if len({repr(inj.get(k)) for inj in injections}) > 1]
    return varied or (keys if len(keys) == 1 else [])



def point_from_entry(entry: dict, swept: list[str],
                     displays: dict[str, tuple[str, float]] | None = None) -> Point:
    """Read the report's figures out of one test entry (the analysis and model ``to_dict()``).

    Measured, U and predicted are the values the verdict compared when it recorded them (the
    prediction per unit of the measured mean), else the analysis' and model's own figures.
    """
    measured = entry.get("measured") or {}
    prediction = entry.get("prediction") or {}
    verdict = entry.get("verdict") or {}
    uncertainty = entry.get("uncertainty") or measured.get("uncertainty") or {}
    decision = str(verdict.get("decision", "")).lower()
    injection = entry.get("injection") or {}
    displays = displays or {k: knob_display(k, [_number(injection.get(k)) or 0.0]) for k in swept}
    label = ", ".join(f"{displays[k][0]} = {_knob_text(injection.get(k), displays[k][1])}"
                      for k in swept) or "—"
    if not verdict and entry.get("outcome") in ("passed", "xfailed", MEASURED):
        decision = NO_VERDICT           # a test that judges no model (e.g. a sensitivity check)
    elif entry.get("outcome") in ("error", "skipped", "not run", NOT_DETERMINABLE) \
            or decision not in DECISIONS:
        decision = NOT_DETERMINED
    return Point(
        test_id=str(entry.get("test_id")),
        outcome=str(entry.get("outcome")),
        x=_number(injection.get(swept[0])) if len(swept) == 1 and \
            not isinstance(injection.get(swept[0]), bool) else None,
        label=label,
        measured_pu=_first_number(verdict.get("measured_pk_pk_pu"), measured.get("pk_pk_pu")),
        u_pu=_first_number(verdict.get("expanded_uncertainty_pu"),
                           uncertainty.get("expanded_pu")),
        predicted_pu=_first_number(verdict.get("predicted_pk_pk_pu"),
                                   prediction.get("pk_pk_pu_of_measured_mean"),
                                   prediction.get("pk_pk_pu")),
        predicted_order=_number(prediction.get("order")),
        lower_pu=_number(verdict.get("lower_limit_pu")),
        upper_pu=_number(verdict.get("upper_limit_pu")),
        decision=decision,
        entry=entry,
    )


def deviations(record: dict, sources: list[SourceSection],
               capture_problems: list[str]) -> list[str]:
    """Real deviations from the method only: selection, interruption or abort, calibration
    override, integrity, tests that errored or did not run (the models' assumptions are method
    notes, :func:`method_notes`)."""
    out = []
    status = record.get("status")
    run = record.get("run") or {}
    if status != "complete":
        out.append(f"INCOMPLETE RUN: {run_status_text(record)}; this report covers only the "
                   f"{sum(t.get('outcome') != 'not run' for t in record.get('tests', []))} "
                   f"test(s) that ran and makes no overall statement of conformity.")
    abort = run.get("abort")
    if abort:
        out.append(f"Bench lost: {abort.get('instrument')} at {abort.get('utc')} during "
                   f"{abort.get('step')}: {abort.get('error')}.")
    selection = run.get("selection") or {}
    if selection.get("deselected"):
        out.append(f"Partial selection: {selection['deselected']} of "
                   f"{selection.get('collected')} collected point(s) deselected "
                   f"(-k {selection.get('keyword') or '—'}, -m {selection.get('markers') or '—'}"
                   f"); command line: {run.get('command_line')}.")
    for item in record.get("pending_captures", []):
        out.append(f"Test '{item.get('test_id')}' was captured ({item.get('file')}, SHA-256 "
                   f"{item.get('sha256')}) but never analysed: the run stopped during that test.")
    out += [f"INTEGRITY: {problem}" for problem in capture_problems]
    for override in record.get("calibration_overrides", []):
        out.append(f"Calibration override: {override.get('role')} s/n "
                   f"{override.get('serial_number')} was used past its due date "
                   f"{override.get('due')}; reason: {override.get('reason')} "
                   f"(by {override.get('by')}).")
    for row in record.get("instruments", []):
        for problem in row.get("problems", []):
            out.append(f"Instrument {row.get('role')} s/n {row.get('serial_number')}: {problem}.")
    if record.get("sim_defects"):
        out.append("Simulated drive with test-only defects: " + ", ".join(
            f"{k} = {v}" for k, v in record["sim_defects"].items()) + ".")
    for test in record.get("tests", []):
        if test.get("outcome") in ("error", "failed", "xpassed", "not run", "skipped",
                                   NOT_DETERMINABLE):
            reason = test.get("message") or test.get("error") or \
                "; ".join(test.get("notes") or []) or "no reason recorded"
            said = is_not_determinable(reason)      # the reason says it already
            out.append(f"Test '{test.get('test_id')}'"
                       + ("" if said else f" {test.get('outcome')}")
                       + (f" in {test['phase']}" if test.get("phase") not in (None, "call")
                          else "")
                       + f": {reason}")
    return out


def method_notes(record: dict, sources: list[SourceSection]) -> list[str]:
    """How the method's models relate to this bench: the paper's assumptions, the plans'
    expectations, disagreements measured against the paper, a simulated bench."""
    out = []
    if (record.get("bench") or {}).get("simulated"):
        out.append("The instruments are simulated (hil.sim digital twin behind the real protocol "
                   "stacks). The simulation does not regulate current ideally, as the paper's "
                   "closed forms assume; differences between measured and predicted ripple can "
                   "come from that assumption.")
    assumptions: dict[str, list[str]] = {}
    for section in sources:
        for point in section.points:
            for text in (point.entry.get("prediction") or {}).get("assumptions") or []:
                users = assumptions.setdefault(str(text), [])
                if section.name not in users:
                    users.append(section.name)
            if point.decision in ("fail", "conditional fail") and point.measured_pu is not None \
                    and point.predicted_pu is not None:
                out.append(f"Disagreement with the paper: '{point.test_id}' measured "
                           f"{fmt_pct(point.measured_pu)} against the predicted "
                           f"{fmt_pct(point.predicted_pu)} (U = {fmt_pct(point.u_pu)}); "
                           f"decision: {point.decision}"
                           + (f" ({reason})." if (reason := (point.entry.get("verdict") or {})
                                                  .get("reason")) else "."))
    out += _expectations(sources)
    for text, users in assumptions.items():
        out.append(f"Paper's assumption ({', '.join(users)}): {text}")
    return out


def _expectations(sources) -> list[str]:
    """Where a plan judged against another expectation than the paper's form: its note, and the
    paper's own figure beside the measured one for every such point."""
    notes: dict[str, list[str]] = {}
    out = []
    for section in sources:
        for point in section.points:
            if point.outcome in ("error", "skipped", NOT_DETERMINABLE, "not run"):
                continue
            for note in point.entry.get("notes") or []:
                users = notes.setdefault(str(note), [])
                if section.name not in users:
                    users.append(section.name)
            prediction = point.entry.get("prediction") or {}
            model = (prediction.get("inputs") or {}).get("model")
            paper = (prediction.get("extras") or {}).get("paper_pk_pk_pu")
            if model not in (None, "paper") and paper is not None \
                    and point.measured_pu is not None:
                out.append(f"'{point.test_id}' ({section.name}): judged against the '{model}' "
                           f"form ({fmt_pct(point.predicted_pu)}); the paper's own form gives "
                           f"{fmt_pct(paper)} (its per-unit base), measured "
                           f"{fmt_pct(point.measured_pu)}.")
    return [f"Plan's expectation ({', '.join(users)}): {note}" for note, users in notes.items()] + out


def fmt_pct(value: float | None, digits: int = 2) -> str:
    """A per-unit value as percent for print, or an em dash if missing."""
    return "—" if value is None else f"{100.0 * value:.{digits}f} %"


def knob_display(name: str | None, values: list[float]) -> tuple[str, float]:
    """Axis label and scale for an injection knob at the user's edge (µs, %, degrees, kHz)."""
    if name is None:
        return "test point", 1.0
    largest = max((abs(v) for v in values), default=0.0)
    base = name.rsplit("_", 1)[0]
    if name.endswith("_s") and 0 < largest < 1e-3:
        return f"{base} (µs)", 1e6
    if name.endswith("_pu"):
        return f"{base} (%)", 100.0
    if name.endswith("_rad"):
        return f"{base} (electrical degrees)" if "angle" in base else f"{base} (deg)", \
            180.0 / math.pi
    if name.endswith("_hz") and largest >= 1000:
        return f"{base} (kHz)", 1e-3
    unit = {"_a": "A", "_s": "s", "_bits": "bits", "_counts": "counts"}
    for suffix, label in unit.items():
        if name.endswith(suffix):
            return f"{name.removesuffix(suffix)} ({label})", 1.0
    return name, 1.0


def fmt(value: Any, digits: int = 4) -> str:
    """Any recorded value for print: numbers to ``digits`` significant figures, lists joined."""
    if value is None:
        return "—"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float) and value.is_integer() and abs(value) < 1e7:
        return str(int(value))
    if isinstance(value, float):
        return f"{value:.{digits}g}"
    if isinstance(value, (list, tuple)):
        return ", ".join(fmt(v, digits) for v in value)
    if isinstance(value, dict):
        return "; ".join(f"{k} {fmt(v, digits)}" for k, v in value.items())
    return str(value)


def _sort_key(injection: dict, swept: list[str]) -> tuple:
    """Order points by their knob values, numerically; a knob not injected sorts last."""
    key = []
    for name in swept:
        value = injection.get(name)
        number = float(value) if isinstance(value, bool) else _number(value)
        key.append((number is None, number or 0.0))
    return tuple(key)


def _knob_text(value: Any, scale: float) -> str:
    if isinstance(value, bool):
        return "on" if value else "off"
    number = _number(value)
    return fmt(None if number is None else number * scale)


def _first_number(*values: Any) -> float | None:
    return next((n for n in map(_number, values) if n is not None), None)


def _number(value: Any) -> float | None:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    return float(value) if math.isfinite(value) else None
