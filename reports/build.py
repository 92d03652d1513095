"""``build_report(record_dir, out_pdf)``: the PDF report as a pure function of a record folder.

Every figure printed comes from ``record.json`` and the raw captures it names (see
``reports.angle_view`` for the one plot that needs the capture). Every hash is checked again
(``hil.record.verify_record``): a record or capture that does not match makes page 1 say
INVALID and name the files. The creation date is the record's, so the same record and revision
give the same PDF; a second report of a record is a new revision (``reports.revisions``).

Page 1 carries the ISO/IEC 17025 §7.8.2 content: laboratory, customer, item tested and when it
was received and tested, method, operator, environment, calibration overrides, the four separate
statements (requirements, model validation, bench self-check, run status and integrity) and the
overall one, "results relate only to the item tested", revision, authorizer and signature line.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

from hil.capture import Capture, atomic_write_bytes
from hil.errors import InputError
from hil.record import RECORD_FILE, capture_path, load_record, utc_now, verify_record
from ripple_hil_reports import bench_as_measured, figures, revisions
from ripple_hil_reports.angle_view import angle_view
from ripple_hil_reports.bench_kind import bench_text
from hil.outcome_kinds import MEASURED, NOT_DETERMINABLE
from ripple_hil_reports.content import (DECISIONS, NO_VERDICT, NOT_DETERMINED, RIPPLE_DEFINITION,
                             VOIDED, ReportContent,
                             SourceSection, fmt, fmt_pct, report_content)
from ripple_hil_reports.document import ReportPDF
from ripple_hil_reports.revisions import Revision
from ripple_hil_reports.statement import (NOT_RUN, accepted, plan_checks, reason_line,
                                          run_status_text)

BUDGET_COLUMNS = ("source", "value", "unit", "distribution", "divisor", "sensitivity",
                  "sensitivity_unit", "contribution_pu", "combination")
#: Short header labels so the budget table's headings fit their columns without breaking words.
BUDGET_LABELS = {"sensitivity": "sens. coeff.", "sensitivity_unit": "sens. unit",
                 "contribution_pu": "contrib. (pu)", "combination": "combined",
                 "distribution": "distribution"}
BUDGET_WIDTHS = {"value": 16, "unit": 11, "distribution": 24, "divisor": 12, "sensitivity": 15,
                 "sensitivity_unit": 16, "contribution_pu": 18, "combination": 16}
#: Captures larger than this in total are listed with their hashes but not attached (they stay
#: in the record folder, hashed). 1 MiB keeps a default run's PDF at ≈ 1.7 MB (25 MiB made it
#: 10.7 MB, ≈ 9.9 MB of it raw captures; issue 22).
MAX_ATTACHED_BYTES = 1 * 1024 * 1024
REFERENCE = ("S. Chen, C. Namuduri, S. Mir, Controller-induced parasitic torque ripples in a PM "
             "synchronous motor, IEEE Trans. Ind. Appl. 38(5), 2002")

STATEMENTS = {
    "pass": "PASS: every point meets its acceptance limits under the decision rule recorded "
            "with its verdict: {rule}.",
    "conditional pass": "CONDITIONAL PASS: every point is within its limits, but at least one "
                        "lies inside the guard band; agreement cannot be stated with 95 % "
                        "confidence (rule recorded: {rule}).",
    "conditional fail": "CONDITIONAL FAIL: at least one point lies outside its limits but "
                        "within the guard band; disagreement is likely, not certain (rule "
                        "recorded: {rule}).",
    "fail": "FAIL: at least one point lies outside its limits (rule recorded: {rule}), shows "
            "a ripple order other than the predicted one, or a check across the sweep "
            "rejected the drive.",
    NOT_DETERMINED: "NOT DETERMINED: a test errored, was skipped, not run or not determinable "
                    "here, so the points that ran cannot state the source (see below).",
    NOT_RUN: "NOT RUN: no test of this source ran.",
    VOIDED: "NOT STATED: the bench self-check failed or did not complete, which voids this "
            "run's model-validation verdicts (the points' decisions below are not a statement).",
    NO_VERDICT: "NO MODEL VERDICT: these tests judge no prediction (their outcomes and any "
                "requirement verdicts are stated elsewhere).",
    MEASURED: "MEASURED, NO VERDICT: these points are measured and recorded; nothing judges "
              "them (their requirement verdicts, if any, are stated under Requirements).",
}


def rule_text(rules: list) -> str:
    """The decision rule(s) the verdicts recorded (``verdict.rule``), in words: ILAC-G8 simple
    acceptance where the guard band factor is 0, guarded acceptance w = factor·U otherwise."""
    texts = []
    for rule in rules:
        if not isinstance(rule, dict):
            continue
        factor = rule.get("guard_band_factor")
        if not isinstance(factor, (int, float)):
            text = str(rule.get("name") or "not recorded")
        elif factor == 0:
            text = "ILAC-G8 simple acceptance (w = 0; U reported beside each point)"
        else:
            text = ("guard band w = U (ILAC-G8 guarded acceptance)" if factor == 1 else
                    f"guard band w = {factor:g}·U (ILAC-G8 guarded acceptance)")
        if text not in texts:
            texts.append(text)
    return "; ".join(texts) or "no rule recorded"


def source_statement(section: SourceSection) -> str:
    """A source page's statement, with the decision rule its points recorded."""
    rules = [(p.entry.get("verdict") or {}).get("rule") for p in section.points]
    return STATEMENTS[section.statement].replace("{rule}", rule_text(rules))


@dataclass
class RenderedReport:
    """A built report: the PDF bytes, what it states, and its page count."""

    pdf: bytes
    content: ReportContent
    pages: int

    def save(self, path: str | Path) -> Path:
        """Write the PDF atomically, readable like any file the user creates."""
        path = Path(path)
        atomic_write_bytes(path, self.pdf)
        umask = os.umask(0)
        os.umask(umask)
        path.chmod(0o666 & ~umask)  # the temp file behind the atomic write was private
        return path


def build_report(record_dir: str | Path, out_pdf: str | Path, *, reason: str | None = None
                 ) -> Path:
    """Issue the next report revision of the record in ``record_dir`` as ``out_pdf``."""
    issue_report(record_dir, out_pdf, reason=reason)
    return Path(out_pdf)


def issue_report(record_dir: str | Path, out_pdf: str | Path, *, reason: str | None = None
                 ) -> "RenderedReport":
    """Issue the next report revision of the record in ``record_dir`` as ``out_pdf``.

    Rev. 1 needs no reason; a later revision does (InputError otherwise), and an existing PDF is
    never overwritten. The revision is logged in the record folder (``reports.jsonl``)."""
    record_dir, out_pdf = Path(record_dir), Path(out_pdf)
    if record_dir.name == RECORD_FILE:
        record_dir = record_dir.parent
    revisions.refuse_overwrite(out_pdf)
    now = utc_now()
    revision = revisions.next_revision(record_dir, reason, now)
    rendered = render_report(record_dir, revision=revision)
    rendered.save(out_pdf)
    revisions.log_revision(record_dir, revision, rendered.content.report_id, out_pdf, now)
    return rendered


def render_report(record_dir: str | Path, *, revision: Revision | None = None
                  ) -> RenderedReport:
    """The report's PDF bytes and what it states; InputError if the record is unreadable."""
    record_dir = Path(record_dir)
    record = load_record(record_dir)
    content = report_content(record, record_dir, verify_record(record_dir, record), revision)
    created = _record_date(record)
    banner = ("INVALID - a hash does not verify" if content.capture_problems else
              f"INCOMPLETE RUN ({record.get('status')})" if content.partial else "")
    pdf = ReportPDF(content.report_id, created, banner)
    _summary_page(pdf, content)
    _statements_pages(pdf, content)
    _method_pages(pdf, content, record_dir)
    for section in content.sources:
        _source_pages(pdf, section, record_dir,
                      (content.record.get("sensitivity") or {}).get(section.name),
                      plan_checks(content.record, section.name))
    _deviations_and_traceability(pdf, content)
    _attach(pdf, content, record_dir, created)
    return RenderedReport(bytes(pdf.output()), content, pdf.pages_count)


def _record_date(record: dict) -> datetime:
    text = record.get("finished_utc") or record.get("created_utc")
    try:
        return datetime.strptime(text, "%Y-%m-%dT%H:%M:%SZ").replace(tzinfo=timezone.utc)
    except (TypeError, ValueError):
        raise InputError(f"record: created_utc = {text!r} is not a UTC time like "
                         f"2026-11-21T05:30:00Z") from None


# ---------------------------------------------------------------------- page 1: summary

def _summary_page(pdf: ReportPDF, content: ReportContent) -> None:
    record = content.record
    loaded = (record.get("bench") or {}).get("loaded") or {}
    lab = (loaded.get("lab") or {}) | {k: v for k, v in (record.get("lab") or {}).items() if v}
    run = record.get("run") or {}
    motor = loaded.get("motor") or {}
    drive = _instrument(record, "drive")
    statement = content.statement
    revision = content.revision
    pdf.add_page()
    pdf.set_font("sans", "B", 15)
    pdf.multi_cell(0, 7, "Controller-induced torque ripple: test report", new_x="LMARGIN",
                   new_y="NEXT")
    if record.get("sim_defects"):
        pdf.para("SIMULATED DRIVE WITH TEST-ONLY DEFECTS: " + ", ".join(
            f"{k} = {v}" for k, v in record["sim_defects"].items())
            + " (a mutation test of the bench software; not a real drive)", size=9, style="B")
    rev_text = f"Rev. {revision.number}"
    if revision.number > 1:
        rev_text += (f" of {revision.issued_utc}, reason: {revision.reason}; supersedes "
                     f"{(revision.supersedes or {}).get('report_id')}")
    operator = run.get("operator")
    pdf.key_values([
        ("Report ID / revision", f"{content.report_id} ({rev_text})"),
        ("Laboratory", ", ".join(x for x in (lab.get("name"), lab.get("address")) if x) or "—"),
        ("Customer", lab.get("customer") or "not stated"),
        ("Item tested: motor", f"{motor.get('model') or '—'}, "
                               f"s/n {motor.get('serial_number') or '—'} "
                               f"({motor.get('pole_count')} poles, "
                               f"Ke {motor.get('ke_v_s_per_rad')} V·s/rad, "
                               f"{motor.get('dc_bus_v')} V dc bus)"),
        ("Item tested: drive", _drive_text(drive)),
        ("Item tested: unit", _unit_text(record)),
        ("Item received", fmt(lab.get("item_received")) if lab.get("item_received")
         else "not stated"),
        ("Tested (UTC)", f"{record.get('created_utc')} to "
                         f"{record.get('finished_utc') or 'not finished'}"),
        ("Report date", f"{(revision.issued_utc or utc_now())[:10]} (date of issue; the run's "
                        "dates: Tested, above)"),
        ("Method", f"ripple-hil test plans; reference: {REFERENCE}"),
        ("Seal", "Ed25519, key " + ((record.get("seal") or {}).get("fingerprint")
                                    or "none (sealed before signing)")),
        ("Operator", f"{operator} (given on the command line)" if operator else
         f"{lab.get('operator')} (bench file; none given on the command line)"
         if lab.get("operator") else "not given"),
        ("Environment", environment_text(record, lab)),
        ("Bench", bench_text(record)),
        ("Bench as measured", bench_as_measured.summary_text(record)),
        ("Run", f"{run_status_text(record)}; exit status "
                f"{fmt(run.get('exit_status'))}; tests: "
                + (", ".join(f"{n} {o}" for o, n in _outcome_counts(record).items() if n)
                   or "none recorded")),
        ("Command line", run.get("command_line") or "not recorded"),
        ("Selection", _selection_text(run.get("selection") or {})),
    ])
    for override in record.get("calibration_overrides", []):
        pdf.para(f"CALIBRATION OVERRIDE: {override.get('role')} s/n "
                 f"{override.get('serial_number')} used past its due date {override.get('due')}; "
                 f"reason: {override.get('reason')}; by {override.get('by')}.", size=8.5,
                 style="B")
    if (run.get("abort") or {}):
        abort = run["abort"]
        pdf.para(f"BENCH LOST: {abort.get('instrument')} at {abort.get('utc')} during "
                 f"{abort.get('step')}: {abort.get('error')}", size=8.5, style="B")
    pdf.heading("Statements", 2, keep_with_mm=40)
    pdf.key_values([
        ("1. Requirements conformity", statement.requirements
         + (f" (demonstration requirement(s): {', '.join(statement.demonstration)})"
            if statement.demonstration else "")),
        ("2. Model validation (vs the paper)", statement.model_text),
        ("3. Bench self-check", statement.self_check
         + (f" ({'; '.join(statement.failed_checks)})" if statement.failed_checks else "")),
        ("4. Run status and integrity", f"{statement.run}; {statement.integrity}"),
    ], key_width=56)
    if content.capture_problems:
        pdf.bullets([f"INVALID: {problem}" for problem in content.capture_problems[:12]]
                    + ([f"... and {len(content.capture_problems) - 12} more"]
                       if len(content.capture_problems) > 12 else []), size=7.5)
    pdf.para(f"Overall: {statement.overall}" + (f" ({statement.reason})" if statement.reason
                                                  else ""), size=11, style="B")
    pdf.para("The results relate only to the item tested, as received, under the conditions "
             "stated. This report shall not be reproduced except in full.", size=7.5, style="I")
    authorizer = lab.get("authorizer")
    pdf.para(f"Authorized by: {authorizer or 'not stated'}"
             + (f", {lab.get('authorizer_function')}" if lab.get("authorizer_function") else ""),
             size=8.5)
    pdf.signature_line("Signature:")


def environment_text(record: dict, lab: dict) -> str:
    """Environmental conditions: the bench file's / command line's statement, else the range of
    a temperature the DAQ recorded with the points, else "not recorded"."""
    if lab.get("environment"):
        return str(lab["environment"])
    temperatures = [t for test in record.get("tests", [])
                    for t in ((test.get("operating_point") or {}).get("temperature_c"),
                              (test.get("measured") or {}).get("temperature_c"))
                    if isinstance(t, (int, float)) and math.isfinite(t)]
    if temperatures:
        return (f"temperature {min(temperatures):.1f} to {max(temperatures):.1f} °C (recorded "
                f"by the DAQ with the points); ambient not recorded")
    return "not recorded"


def _selection_text(selection: dict) -> str:
    if not selection:
        return "not recorded"
    parts = [f"{selection.get('selected')} of {selection.get('collected')} collected test(s) "
             f"selected"]
    if selection.get("deselected"):
        parts.append(f"{selection['deselected']} deselected")
    if selection.get("keyword"):
        parts.append(f"-k {selection['keyword']}")
    if selection.get("markers"):
        parts.append(f"-m {selection['markers']}")
    if selection.get("sources"):
        parts.append("sources: " + ", ".join(str(s) for s in selection["sources"] if s))
    return "; ".join(parts)


# ---------------------------------------------------------------------- statements in detail

def _requirement_decision(verdict: dict) -> str:
    """The ILAC-G8 zone, and for a value within U of the limit whether its rule accepted it
    (the guarded rule does not accept a conditional pass; statement 1 then says FAIL)."""
    zone = str(verdict.get("decision", ""))
    if zone not in ("conditional pass", "conditional fail"):
        return zone.upper()
    return f"{zone.upper()}: {'accepted' if accepted(verdict) else 'not accepted'}"


def _statements_pages(pdf: ReportPDF, content: ReportContent) -> None:
    record = content.record
    pdf.add_page()
    pdf.heading("Requirements")
    requirements = [(t, r) for t in record.get("tests", []) for r in t.get("requirements") or []]
    listed = (record.get("requirements") or {}).get("lines") or []
    if requirements:
        pdf.grid(["id", "requirement", "point", "measured ± U (k = 2)", "rule", "decision"],
                 [[r.get("id"), f"{r.get('name')} {r.get('limit_text') or _limit(r)}",
                   t.get("test_id", "").split("::")[-1],
                   f"{fmt(r.get('measured'))} ± {fmt(r.get('expanded_uncertainty'), 2)} "
                   f"{r.get('unit') or ''}", r.get("rule"), _requirement_decision(r)
                   + (" (demonstration)" if r.get("demonstration") else "")]
                  for t, r in requirements], widths=(16, 0, 38, 30, 15, 26))
    else:
        pdf.para("No requirement was judged." if listed else "No requirements were given for "
                 "this run (give --requirements SPEC.toml).")
    judged = {r.get("id") for _, r in requirements}
    unjudged = [line for line in listed if line.get("id") not in judged]
    if unjudged:
        pdf.para("Requirements given but applied to no measured point: " + ", ".join(
            str(line.get("id")) for line in unjudged), size=7.5)
    source = record.get("requirements_source") or (record.get("requirements") or {})
    if source.get("sha256"):
        pdf.para(f"Requirements file {source.get('path') or source.get('source')}, SHA-256 "
                 f"{source.get('sha256')}.", size=7)

    pdf.heading("Model validation (measured against the paper's prediction)", 2)
    rows = []
    for section in content.sources:
        counts = {d: sum(p.decision == d for p in section.points)
                  for d in (*DECISIONS, NOT_DETERMINED, NO_VERDICT)}
        rows.append([section.name, str(len(section.points)),
                     ", ".join(f"{n} {d}" for d, n in counts.items() if n),
                     section.statement.upper()])
    pdf.grid(["source", "points", "decisions", "statement"], rows, widths=(38, 14, 0, 36))
    for section in content.sources:
        pdf.para(f"{section.name}: {source_statement(section)}", size=7.5)

    pdf.heading("Bench self-check", 2)
    if content.self_checks:
        pdf.grid(["check", "measured", "expected", "tolerance", "unit", "result", "detail"],
                 [[c.get("name"), fmt(c.get("measured")), fmt(c.get("expected")),
                   fmt(c.get("tolerance")), c.get("unit") or "",
                   "not completed" if c.get("passed") is None else
                   "pass" if c.get("passed") else "FAILED", c.get("detail") or ""]
                  for c in content.self_checks], widths=(28, 16, 16, 16, 12, 20, 0), size=7)
    else:
        pdf.para("No bench self-check was run.")
    if content.map_cells:
        pdf.heading("Ripple map (the drive as it is, nothing injected)", 2, keep_with_mm=70)
        figures.heat_map(pdf, content.map_cells, "pk-pk torque ripple over speed × current")
    diagnosis = record.get("diagnosis")
    if diagnosis:
        try:
            from ripple_hil_reports.diagnosis_section import add_diagnosis_section
        except ImportError:
            pdf.para("A diagnosis was recorded, but this installation cannot draw it "
                     "(reports.diagnosis_section missing).")
        else:
            add_diagnosis_section(pdf, diagnosis)


def _limit(requirement: dict) -> str:
    limit = requirement.get("limit") or {}
    unit = requirement.get("unit") or ""
    if "min" in limit and "max" in limit:
        return f"{limit['min']}..{limit['max']} {unit}"
    if "max" in limit:
        return f"≤ {limit['max']} {unit}"
    if "min" in limit:
        return f"≥ {limit['min']} {unit}"
    return ""


def _outcome_counts(record: dict) -> dict[str, int]:
    """The one count (``reports.statement.outcome_counts``: each test once, by outcome)."""
    from ripple_hil_reports.statement import outcome_counts

    return outcome_counts(record)


def _drive_text(drive: dict | None) -> str:
    if not drive:
        return "—"
    identity = drive.get("identity") or {}
    firmware = next((identity[k] for k in ("firmware_version", "software_version", "firmware",
                                           "sw_version") if identity.get(k)), None)
    return (f"{drive.get('model')}, s/n {drive.get('serial_number')}, firmware "
            f"{firmware or 'not reported'}")


def _unit_text(record: dict) -> str:
    """The unit under test's serial as stated, the drive's own 0x1018 identity, the check
    between them and any override (``hil.dut``)."""
    from hil.dut import item_tested

    return item_tested(record) or "serial not recorded (a record from before issue 32)"


def _instrument(record: dict, role: str) -> dict | None:
    return next((row for row in record.get("instruments", []) if row.get("role") == role), None)


# ---------------------------------------------------------------------- method, conditions

def _method_pages(pdf: ReportPDF, content: ReportContent, record_dir: Path) -> None:
    record = content.record
    tests = record.get("tests", [])
    pdf.add_page()
    pdf.heading("Method")
    plans = sorted({(t.get("nodeid") or "").split("::")[0] for t in tests} - {""})
    pdf.key_values([
        ("Sources tested", ", ".join(s.name for s in content.sources) or "none"),
        ("Test plans run", ", ".join(plans) or "not recorded"),
        ("Reference", "S. Chen, C. Namuduri, S. Mir, Controller-induced parasitic torque ripples "
                      "in a PM synchronous motor, IEEE Trans. Ind. Appl. 38(5), 2002"),
        ("Ripple definition", RIPPLE_DEFINITION),
    ])
    pdf.heading("Decision rule (agreed before measuring)", 2)
    rule = record.get("decision_rule") or {}
    pdf.key_values([(k, fmt(v)) for k, v in rule.items()] or [("rule", "not recorded")])
    used: dict[str, list[str]] = {}
    for test in tests:
        applied = (test.get("verdict") or {}).get("rule")
        if isinstance(applied, dict):
            used.setdefault(fmt(applied), []).append(test.get("test_id"))
    if used:
        pdf.para("Rules applied by the verdicts (as recorded with each verdict):", size=7.5)
        pdf.bullets([f"{text} ({len(ids)} test{'s' if len(ids) > 1 else ''})"
                     for text, ids in sorted(used.items())], size=7)

    pdf.heading("Test conditions", 2)
    conditions = sorted({(fmt(op.get("speed_rpm")), fmt(op.get("current_a")),
                          fmt(_degrees(op.get("current_angle_rad"))), fmt(op.get("dc_bus_v")),
                          fmt(op.get("temperature_c")))
                         for op in (t.get("operating_point") for t in tests) if op})
    pdf.grid(["speed (rpm)", "current, peak (A)", "current angle φ (elec. deg)", "dc bus (V)",
              "temperature (°C)"], [list(c) for c in conditions])
    pdf.para("A dash means the value was not recorded (temperature is recorded only where the "
             "bench measures it).", size=7, style="I")
    points = [t.get("operating_point") or {} for t in tests]
    moved = [op for op in points
             if op.get("dyno_speed_setpoint_rpm") not in (None, op.get("speed_rpm"))]
    if moved:
        largest = max(abs(op["dyno_speed_setpoint_rpm"] / op["speed_rpm"] - 1.0) for op in moved)
        pdf.para(f"At {len(moved)} point(s) the dyno was set off the nominal speed by at most "
                 f"{largest:.3%}, where the drive's PWM carrier would have been locked to the "
                 f"rotor (the same carrier phase every revolution; hil.carrier_lock): each "
                 f"point's dyno setpoint is in the record.", size=7, style="I")
    locked = sum(bool(op.get("carrier_locked")) for op in points)
    if locked:
        pdf.para(f"At {locked} point(s) no speed within 0.5 % unlocked the PWM carrier from the "
                 "rotor: their per-period patterns (word length, PWM resolution, dead time) "
                 "depend on the carrier's phase when the drive was enabled (record: "
                 "operating_point.carrier_locked).", size=7, style="I")

    pdf.heading("Instruments", 2)
    pdf.grid(["role", "model", "serial number", "range", "accuracy class", "calibrated", "due"],
             [[fmt(r.get(k)) for k in ("role", "model", "serial_number", "range",
                                        "accuracy_class", "calibration_date", "calibration_due")]
              for r in record.get("instruments", [])],
             widths=(13, 0, 26, 25, 20, 18, 18))
    identities = [(r.get("role"), r.get("identity")) for r in record.get("instruments", [])
                  if r.get("identity")]
    if identities:
        pdf.para("Identities as queried from the instruments: " + "; ".join(
            f"{role}: {fmt(identity)}" for role, identity in identities), size=7)

    pdf.heading("Bench as measured (characterisation before the plans)", 2)
    rows = bench_as_measured.table_rows(record)
    if rows:
        pdf.grid(["parameter", "stated", "measured ± U (k = 2)", "unit", "predictions use"], rows,
                 widths=(34, 20, 36, 16, 0))
    else:
        pdf.para(bench_as_measured.summary_text(record), size=7.5)
    rechecks = bench_as_measured.recheck_rows(record)
    if rechecks:
        pdf.para("The winding measured again before each plan (R in Ω, L in H: held → measured "
                 "± U, k = 2); where it drifted beyond U the characterisation was repeated, and "
                 "the plan's predictions read the new values where they differ from the bench "
                 "file beyond U (the stated ones where they confirm it):", size=7.5)
        pdf.grid(["before plan", "R", "L", "decision"], rechecks, widths=(30, 50, 60, 0))

    pdf.heading("Signal chain", 2)
    pdf.grid(["test", "samples", "sample rate (Hz)", "encoder counts/rev", "revolutions",
              "angle grid (points/rev)"], _signal_rows(tests, record_dir),
             widths=(0, 18, 24, 26, 20, 30))

    pdf.heading("Software", 2)
    software = record.get("software") or {}
    packages = software.get("packages") or {}
    pdf.key_values([
        ("ripple-hil version", fmt(software.get("version"))),
        ("git commit", f"{fmt(software.get('git_sha'))} (uncommitted changes: "
                       f"{fmt(software.get('git_dirty'))})"),
        ("Python", f"{fmt(software.get('python'))} on {fmt(software.get('platform'))}"),
        ("Packages", ", ".join(f"{k} {v}" for k, v in packages.items())),
        ("Bench file SHA-256", fmt(record["bench"].get("sha256"))),
    ])


def _degrees(radians) -> float | None:
    return math.degrees(radians) if isinstance(radians, (int, float)) else None


def _signal_rows(tests: list[dict], record_dir: Path) -> list[list[str]]:
    rows = []
    for test in tests:
        capture = test.get("capture") or {}
        meta = _capture_meta(record_dir, capture.get("file"))
        measured = test.get("measured") or {}
        settings = next((measured[key] for key in ("analysis_settings", "settings")
                         if isinstance(measured.get(key), dict)), {})
        grid = settings.get("samples_per_rev", measured.get("samples_per_rev"))
        if grid is None and measured.get("angle_grid_rad") is not None:
            grid = len(measured["angle_grid_rad"])
        rows.append([test.get("test_id"), fmt(capture.get("n_samples")),
                     fmt(capture.get("sample_rate_hz")),
                     fmt(meta.get("encoder_counts_per_rev")),
                     fmt(measured.get("revolutions")), fmt(grid)])
    return rows


def _capture_meta(record_dir: Path, relative: str | None) -> dict:
    """A capture's ``meta``, read from its header alone (not its channels)."""
    path = capture_path(record_dir, relative)
    if path is None:
        return {}
    try:
        return Capture.read_meta(path)
    except InputError:      # a damaged capture: the traceability table names the problem
        return {}


# ---------------------------------------------------------------------- per source

def _source_pages(pdf: ReportPDF, section: SourceSection, record_dir: Path,
                  sensitivity: dict | None = None,
                  checks: list[tuple[str, dict]] = ()) -> None:
    pdf.add_page()
    pdf.heading(f"Source: {section.name}")
    pdf.para(f"Statement: {source_statement(section)}", style="B")
    if section.reasons:
        pdf.bullets(section.reasons[:20] + ([f"... and {len(section.reasons) - 20} more"]
                                            if len(section.reasons) > 20 else []), size=7.5)
    if sensitivity:
        pdf.para(_sensitivity_text(sensitivity), size=8)
    for name, check in checks:
        verdict = "ACCEPTED" if check.get("accepted") else "NOT ACCEPTED"
        pdf.para(f"{name.replace('_', ' ').capitalize()} check ({check.get('statistic', '')}): "
                 f"{check['statement']}: {verdict}.", size=8)
    if figures.sweep(pdf, section):
        pdf.caption("Measured ripple with its expanded uncertainty (k = 2), the paper's "
                    "prediction and the tolerance limits of the decision rule where recorded.")
    pdf.heading("Points", 2)
    pdf.grid(["injected", "test", "measured", "U (k = 2)", "predicted", "pred. order", "outcome",
              "verdict"],
             [[p.label, p.test_id.split("::")[-1],
               fmt_pct(p.measured_pu), fmt_pct(p.u_pu), fmt_pct(p.predicted_pu),
               fmt(p.predicted_order), p.outcome, p.decision] for p in section.points],
             widths=(34, 0, 17, 15, 17, 12, 15, 22))
    pdf.para("Ripple figures in % of the mean torque at the operating point; the full test ids "
             "and capture hashes are in the traceability table.", size=7, style="I")
    # the tests that reached no verdict, worded as the statement's reasons above (a reason
    # that says "not determinable" is not prefixed with its outcome again); those already
    # listed above are not repeated
    listed = set(section.reasons[:20])
    unfinished = [line for line in (_unfinished_line(p) for p in section.points
                                     if p.outcome in ("error", "skipped", NOT_DETERMINABLE,
                                                      "not run"))
                  if line not in listed]
    if unfinished:
        pdf.bullets(unfinished, size=7.5)
    worst = section.worst
    if worst is None:
        pdf.para("No point of this source has a measured ripple; no waveform to show.")
        return
    pdf.heading(f"Worst point: {worst.test_id} (measured {fmt_pct(worst.measured_pu)})", 2,
                keep_with_mm=90)
    view = angle_view(worst.entry, record_dir)
    if view.problem:
        pdf.para(f"Torque-against-angle plot and order spectrum not shown: {view.problem}.")
    else:
        if view.angle_grid_rad is not None and view.sync_average_nm is not None:
            switching = view.analysis == "switching"
            what = ("pk-pk of the estimated torque within each PWM period" if switching
                    else "torque")
            figures.angle(pdf, view.angle_grid_rad, view.revolution_matrix_nm,
                          view.sync_average_nm, f"{section.name}: {what} against rotor angle",
                          ylabel=f"{'within-period pk-pk' if switching else 'torque'} (N·m)")
        if view.orders is not None and view.amplitude_nm is not None:
            figures.spectrum(pdf, view.orders, view.amplitude_nm, worst.predicted_order,
                             f"{section.name}: order spectrum of the synchronous average")
        pdf.para(f"Source of the curves: {view.how}.", size=7, style="I")
        if view.mismatch:
            pdf.para(f"Warning: {view.mismatch}", style="B")
    _budget(pdf, worst.entry)


def _unfinished_line(point) -> str:
    """``test: outcome: reason`` of a point without a verdict, as statement 2's reasons word it."""
    return reason_line({**point.entry, "test_id": point.test_id, "outcome": point.outcome,
                    "message": reason_of(point.entry)})


def reason_of(entry: dict) -> str:
    """Why a test did not run to a verdict, as recorded: its message (a skip's reason), its
    error, its notes."""
    return (entry.get("message") or entry.get("error") or "; ".join(entry.get("notes") or [])
            or "no reason recorded")


def _sensitivity_text(fit: dict) -> str:
    """The sweep's sensitivity check (testplans/sensitivity.py) in one sentence."""
    kind = "scaling exponent" if fit.get("mode") == "scaling" else "slope"
    low, high = fit.get("limits") or (None, None)
    text = (f"Sensitivity across the sweep ({len(fit.get('points') or [])} points): measured "
            f"against expected ripple, {kind} {fmt(fit.get('slope'))} ± "
            f"{fmt(2 * fit.get('slope_u', float('nan')), 2)} (k = 2), limits [{fmt(low)}, "
            f"{fmt(high)}]: {str(fit.get('decision', '')).upper()}.")
    per_knob = fit.get("per_knob")
    if per_knob:
        knob = per_knob["knob"]
        # % of the mean torque per µs for a time knob (dead time), else per unit of the knob
        scale, unit = (1e-4, "µs") if knob.endswith("_s") else (100.0, knob.rsplit("_", 1)[-1])
        text += (f" Ripple per {unit} of {knob}: measured "
                 f"{fmt(per_knob['measured_pu_per_unit'] * scale)} %, expected "
                 f"{fmt(per_knob['expected_pu_per_unit'] * scale)} %.")
    return text


def _budget(pdf: ReportPDF, entry: dict) -> None:
    uncertainty = entry.get("uncertainty") or (entry.get("measured") or {}).get("uncertainty")
    pdf.heading("Uncertainty budget (worst point)", 2)
    rows = (uncertainty or {}).get("rows") or (uncertainty or {}).get("budget")
    if not rows:
        pdf.para("No uncertainty budget recorded for this point.")
        return
    known = [c for c in BUDGET_COLUMNS if any(c in row for row in rows)]
    columns = known + [c for c in dict.fromkeys(k for row in rows for k in row)
                       if c not in known]
    widths = tuple(BUDGET_WIDTHS.get(c, 0) for c in columns)
    pdf.grid([BUDGET_LABELS.get(c, c.replace("_", " ")) for c in columns],
             [[fmt(row.get(c)) for c in columns] for row in rows], widths=widths, size=7)
    scalars = [(k.replace("_", " "), fmt(v)) for k, v in uncertainty.items()
               if not isinstance(v, (list, dict))]
    if scalars:
        pdf.key_values(scalars)
    notes = uncertainty.get("notes") or []
    if notes:
        pdf.bullets([str(note) for note in notes], size=7)


# ---------------------------------------------------------------------- end matter

def _deviations_and_traceability(pdf: ReportPDF, content: ReportContent) -> None:
    record = content.record
    pdf.add_page()
    pdf.heading("Deviations from the method")
    pdf.bullets(content.deviations or ["None."])
    pdf.heading("Method notes: the models' assumptions and the plans' expectations", 2)
    pdf.bullets(content.method_notes or ["None."], size=7.5)
    pdf.heading("Traceability: raw captures")
    pdf.para("SHA-256 of each raw capture as written before analysis. The captures and "
             "record.json are attached to this PDF where their size allows (see below).", size=7.5)
    rows = [[f"{t.get('test_id')}\n{(t.get('capture') or {}).get('file') or 'no capture'}",
             (t.get("capture") or {}).get("sha256") or "—"] for t in record.get("tests", [])]
    rows += [[f"{p.get('test_id')} (captured, not analysed)\n{p.get('file')}", p.get("sha256")]
             for p in record.get("pending_captures", [])]
    pdf.grid(["test / capture file", "SHA-256"], rows, widths=(0, 96), size=7,
             mono_columns=(1,))
    if content.capture_problems:
        pdf.para("INVALID: integrity check found problems: " + "; ".join(
            content.capture_problems), style="B")
    else:
        pdf.para("Integrity check: record.json matches its seal, and every capture named in the "
                 "record is present and its SHA-256 matches.")


def _attach(pdf: ReportPDF, content: ReportContent, record_dir: Path, created: datetime) -> None:
    record_json = (record_dir / RECORD_FILE).read_bytes()
    pdf.embed_file(bytes=record_json, basename=RECORD_FILE, modification_date=created,
                   creation_date=created, desc="run record", compress=True,
                   mime_type="application/json", associated_file_relationship="Source")
    attached, skipped, total = [], [], 0
    files = [(t.get("capture") or {}).get("file") for t in content.record.get("tests", [])]
    files += [p.get("file") for p in content.record.get("pending_captures", [])]
    for relative in dict.fromkeys(f for f in files if f):
        path = capture_path(record_dir, relative)
        if path is None or not path.is_file():
            continue
        size = path.stat().st_size
        if total + size > MAX_ATTACHED_BYTES:
            skipped.append(relative)
            continue
        total += size
        pdf.embed_file(bytes=path.read_bytes(), basename=relative.replace("/", "_"),
                       modification_date=created, creation_date=created,
                       desc=f"raw capture {relative}", mime_type="application/octet-stream",
                       associated_file_relationship="Data")
        attached.append(relative)
    pdf.heading("Attachments", 2)
    pdf.para("Embedded in this PDF as associated files (PDF/A-3 style; open the attachments "
             "panel of a PDF reader):", size=7.5)
    pdf.bullets([f"{RECORD_FILE} (the run record)"] + attached, size=7)
    if skipped:
        pdf.para(f"Not attached (over {MAX_ATTACHED_BYTES // 2**20} MiB in total; keep them "
                 f"with the record folder): {', '.join(skipped)}.")
    pdf.ln(4)
    pdf.para(f"End of report {content.report_id}", size=9, style="B")
