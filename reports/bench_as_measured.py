"""The bench as measured, stated beside the bench file (issue 29 Build 4; design.md §11: the
bench is measured, not believed): page 1's line and the method pages' table, from the record's
``characterisation`` and ``characterisation_rechecks`` sections.

A motor that disagrees with its nameplate beyond U is a note about the motor (it is not the drive
under test); the drive's loop against its documentation is judged by the characterisation plan
(testplans/test_characterisation.py), whose outcome page 1 states with the other tests.
"""

from __future__ import annotations

from hil.characterisation.recheck import CONFIRMED, RECHARACTERISED

NAMES = {"phase_resistance_ohm": "R", "phase_inductance_h": "L", "ke_v_s_per_rad": "Ke",
         "current_loop_bandwidth_hz": "current loop bandwidth",
         "bandwidth_hz": "torque transducer bandwidth"}
UNITS = {"ohm": "Ω", "H": "H", "V*s/rad": "V·s/rad", "Hz": "Hz"}


def _num(value) -> str:
    return "—" if value is None else f"{value:.4g}"


def _measured(row: dict) -> str:
    return f"{_num(row.get('measured'))} ± {_num(row.get('U_k2'))}"


def _rechecks(record: dict) -> list[dict]:
    return ((record.get("characterisation_rechecks") or {}).get("rechecks")) or []


def summary_text(record: dict) -> str:
    """Page 1: what disagreed with the bench file, what the predictions used, and whether the
    winding was characterised again during the run."""
    section = record.get("characterisation")
    if not section:
        return "not characterised (no characterisation in the record): the predictions use the " \
               "bench file as stated"
    if section.get("failed"):
        return f"the characterisation failed ({section['failed']}): no plan was judged"
    rows = section.get("stated_vs_measured") or []
    off = [f"{NAMES.get(r['name'], r['name'])} {_measured(r)} {UNITS.get(r['unit'], r['unit'])} "
           f"(stated {_num(r['stated'])})" for r in rows if r.get("disagrees")]
    text = "at the start of the run, " + (
        "measured beyond U (k = 2) from the bench file, the predictions use the measured: "
        + "; ".join(off) if off else
        "every measured value confirms the bench file within U (k = 2)" if rows else
        "nothing identified: the predictions use the bench file as stated")
    missing = sorted(section.get("not_identified") or {})
    if missing:
        text += "; not identified (bench file used): " + ", ".join(
            NAMES.get(name, name) for name in missing)
    rechecks = _rechecks(record)
    measured = [entry for entry in rechecks if entry.get("decision") in (CONFIRMED,
                                                                         RECHARACTERISED)]
    again = [entry for entry in measured if entry.get("decision") == RECHARACTERISED]
    if measured:
        text += (f"; the winding measured again before {len(measured)} plan(s), "
                 f"re-characterised before {len(again)}" + (_drift(again) if again else ""))
    missed = [entry.get("before_plan") or "?" for entry in rechecks
              if entry.get("decision") not in (CONFIRMED, RECHARACTERISED)]
    if missed:
        text += (f"; NOT measured again before {', '.join(missed)} (the voltage was beyond the "
                 f"DAQ's range: those plans' predictions use the R and L held before them)")
    return text + " (motor values are notes about the motor, not the drive under test)"


def _drift(entries: list[dict]) -> str:
    """The range of R the re-characterisations measured, as " (R measured between a and b Ω…)"."""
    values = [((entry.get("phase_resistance_ohm") or {}).get("measured") or {}).get("value")
              for entry in entries]
    values = [value for value in values if value is not None]
    if not values:
        return ""
    return (f" (R measured between {_num(min(values))} and {_num(max(values))} Ω; each plan "
            f"in the Method pages)")


def table_rows(record: dict) -> list[list[str]]:
    """The method pages' table: parameter, stated, measured ± U (k = 2), unit, what the
    predictions use."""
    rows = (record.get("characterisation") or {}).get("stated_vs_measured") or []
    return [[NAMES.get(r["name"], r["name"]), _num(r.get("stated")), _measured(r),
             UNITS.get(r.get("unit"), r.get("unit") or "—"), r.get("predictions_use") or "—"]
            for r in rows]


def recheck_rows(record: dict) -> list[list[str]]:
    """One row per recheck: the plan it preceded, R held → measured ± U, L, the decision."""
    out = []
    for entry in _rechecks(record):
        r, l_ = entry.get("phase_resistance_ohm") or {}, entry.get("phase_inductance_h") or {}
        out.append([entry.get("before_plan") or "—",
                    f"{_num((r.get('held') or {}).get('value'))} → "
                    f"{_num((r.get('measured') or {}).get('value'))} ± "
                    f"{_num((r.get('measured') or {}).get('U_k2'))}",
                    f"{_num((l_.get('held') or {}).get('value'))} → "
                    f"{_num((l_.get('measured') or {}).get('value'))} ± "
                    f"{_num((l_.get('measured') or {}).get('U_k2'))}",
                    (entry.get("decision") or "—")
                    + (f": {entry['reason']}" if entry.get("reason") else "")])
    return out
