"""The report states the bench as measured beside the bench file (issue 29 Build 4) — from the
record's sections, never more than they hold."""

from ripple_hil_reports.bench_as_measured import recheck_rows, summary_text, table_rows

ROWS = [
    {"name": "phase_resistance_ohm", "stated": 0.055, "measured": 0.0715, "U_k2": 0.0004,
     "unit": "ohm", "disagrees": True, "predictions_use": "measured"},
    {"name": "phase_inductance_h", "stated": 3.85e-5, "measured": 3.86e-5, "U_k2": 2e-6,
     "unit": "H", "disagrees": False,
     "predictions_use": "stated (the measurement confirms it within U)"},
]


def _entry(plan, held, now, decision):
    return {"before_plan": plan, "decision": decision,
            "phase_resistance_ohm": {"unit": "ohm", "held": {"value": held, "U_k2": 1e-4},
                                     "measured": {"value": now, "U_k2": 1e-4}}}


def test_a_motor_off_its_nameplate_is_named_with_what_the_predictions_used():
    record = {"characterisation": {"stated_vs_measured": ROWS,
                                   "not_identified": {"bandwidth_hz": "no [torque] bandwidth"}}}
    text = summary_text(record)
    assert "R 0.0715 ± 0.0004 Ω (stated 0.055)" in text
    assert "L " not in text.split("not identified")[0]        # L confirmed: not listed as off
    assert "not identified (bench file used): torque transducer bandwidth" in text
    assert "not the drive under test" in text
    assert [row[0] for row in table_rows(record)] == ["R", "L"]
    assert table_rows(record)[1][4].startswith("stated")


def test_a_bench_as_stated_and_a_record_without_a_stage_say_so():
    confirmed = [dict(row, disagrees=False) for row in ROWS]
    assert "confirms the bench file" in summary_text(
        {"characterisation": {"stated_vs_measured": confirmed}})
    assert summary_text({}).startswith("not characterised")
    assert "failed (boom)" in summary_text({"characterisation": {"failed": "boom"}})
    assert table_rows({}) == [] and recheck_rows({}) == []


def test_the_rechecks_are_counted_and_the_drift_stated():
    record = {"characterisation": {"stated_vs_measured": ROWS},
              "characterisation_rechecks": {"rechecks": [
                  _entry("dc_offset", 0.0715, 0.0716, "confirmed"),
                  _entry("dead_time", 0.0716, 0.0801, "re-characterised"),
                  _entry("encoder", 0.0801, 0.0745, "re-characterised")]}}
    text = summary_text(record)
    assert text.startswith("at the start of the run, measured beyond U")
    assert "the winding measured again before 3 plan(s), re-characterised before 2" in text
    assert "NOT measured again" not in text
    assert "R measured between 0.0745 and 0.0801 Ω" in text
    rows = recheck_rows(record)
    assert rows[1] == ["dead_time", "0.0716 → 0.0801 ± 0.0001", "— → — ± —", "re-characterised"]
    not_rechecked = {"before_plan": "encoder", "decision": "not rechecked",
                     "reason": "the terminal voltage is beyond the DAQ's vab_v range"}
    assert recheck_rows({"characterisation_rechecks": {"rechecks": [not_rechecked]}})[0][3] \
        == "not rechecked: the terminal voltage is beyond the DAQ's vab_v range"
    record["characterisation_rechecks"]["rechecks"].append(not_rechecked)
    text = summary_text(record)
    assert "measured again before 3 plan(s)" in text          # not 4: one was not measured
    assert "NOT measured again before encoder" in text
