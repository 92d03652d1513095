"""The pre-flight skips a point outside its plan's validity region as "not determinable here"
before any bench command, runs the rest, and a correct drive passes where the region allows —
off the default point (250 rpm / 10 A; braking at −2300 rpm, beyond the motoring voltage limit)."""

from __future__ import annotations

import subprocess
import sys
import tomllib
from pathlib import Path

import pytest
import tomli_w

from hil.config import example_bench_path
from hil.outcome_kinds import NOT_DETERMINABLE_PREFIX
from hil.record import load_record
from ripple_hil_testplans import conditions as c

PLANS = Path(c.__file__).parent


def bench_at(tmp_path: Path, speed_rpm: float, current_a: float) -> Path:
    table = tomllib.loads(example_bench_path("sim-bench").read_text())
    table["operating_point"] = {"speed_rpm": speed_rpm, "current_a": current_a,
                                "current_angle_deg": 0.0}
    # no stated noise: the floor stays two counts of the resolution (hil.validity), which
    # refuses 12 bits at 250 rpm / 10 A; with the shipped bench's stated noise it is judged
    table["torque"].pop("noise_rms_nm", None)
    path = tmp_path / "bench.toml"
    path.write_text(tomli_w.dumps(table))
    return path


def run(tmp_path: Path, bench: Path, plan: str, *extra: str):
    records = tmp_path / "records"
    done = subprocess.run([sys.executable, "-m", "pytest", str(PLANS / plan), "-q",
                           "-p", "no:cacheprovider", "--hil-bench", str(bench),
                           "--hil-record", str(records), *extra],
                          capture_output=True, text=True, timeout=300, cwd=tmp_path)
    record = load_record(sorted(records.iterdir())[-1])
    return done, {t["test_id"].split("::")[-1]: t for t in record["tests"]}


def test_word_length_12_bit_at_250_rpm_10_a_is_not_determinable_and_the_rest_pass(tmp_path):
    done, tests = run(tmp_path, bench_at(tmp_path, 250.0, 10.0), "test_word_length.py",
                      "-k", "not sensitivity")
    refused = tests["test_word_length[word_length_bits=12]"]
    assert refused["outcome"] in ("skipped", "not determinable"), refused
    assert refused["message"].startswith(NOT_DETERMINABLE_PREFIX + "ripple not resolvable")
    assert not refused.get("capture")                 # never driven: nothing captured
    for bits in (8, 10):                              # a correct drive, off the default point
        assert tests[f"test_word_length[word_length_bits={bits}]"]["outcome"] == "passed"
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]


def test_braking_beyond_the_motoring_voltage_limit_is_driven_and_a_correct_drive_passes(tmp_path):
    # 20 A reaches V_dc/√3 at 1709 rpm motoring; braking at −2300 rpm needs 6.74 V of 6.93 V
    done, tests = run(tmp_path, bench_at(tmp_path, -2300.0, 20.0), "test_dc_offset.py",
                      "-k", "test_dc_offset[0.01-0.01]")
    point = tests["test_dc_offset[0.01-0.01]"]
    assert point["outcome"] == "passed", point.get("message") or done.stdout[-2000:]
    assert point["operating_point"]["speed_rpm"] == pytest.approx(-2300.0)


def test_a_run_whose_first_points_are_refused_still_agrees_its_rules_first(tmp_path):
    """The self-check runs first; refused (2500 rpm / 20 A needs more than V_dc/√3), it is
    skipped after the decision rules and the regions are in the record, not before."""
    done, tests = run(tmp_path, bench_at(tmp_path, 2500.0, 20.0), "test_self_check.py")
    # every point refused as not determinable: nothing judged, exit 9 (EXIT_NOTHING_JUDGED)
    assert done.returncode == 9, done.stdout[-2000:] + done.stderr[-2000:]
    entry = tests["test_bench_self_check"]
    assert entry["message"].startswith(NOT_DETERMINABLE_PREFIX + "voltage headroom"), entry
    record = load_record(sorted((tmp_path / "records").iterdir())[-1])
    assert record["decision_rule"]["validity_regions"]["self_check"]["braking"] is True


def test_the_self_check_runs_near_the_voltage_limit_of_a_fast_motor(tmp_path):
    """An 8-pole 48 V motor at −2475 rpm (165 Hz electrical): the self-check's 7919 Hz resolves
    orders up to 23 (23.99), and its analysed band follows (``conditions.self_check_max_order``) instead of
    refusing the module — the angle reference with it — at every near-limit point (found on the
    foreign bench, issue 30). The correct drive passes the self-check; the angle reference is
    refused, saying why: the line back EMF there (38.1 V) is beyond the DAQ's ±32.8 V v_ab
    channel (it failed with a clipped capture once the module was no longer refused)."""
    table = tomllib.loads(bench_at(tmp_path, -2475.0, 20.0).read_text())
    table["motor"] |= {"model": "8-pole 48 V PMSM (study)", "serial_number": "STUDY-P8",
                       "pole_count": 8, "dc_bus_v": 48.0, "phase_resistance_ohm": 0.12,
                       "phase_inductance_h": 0.3e-3, "max_reactance_ohm": 0.4,
                       "ke_v_s_per_rad": 0.06, "ke_definition": "rms_phase"}
    bench = tmp_path / "p8.toml"
    bench.write_text(tomli_w.dumps(table))
    done, tests = run(tmp_path, bench, "test_self_check.py", "-k",
                      "test_bench_self_check or test_angle_reference")
    check = tests["test_bench_self_check"]
    assert check["outcome"] == "passed", (check.get("message"), done.stdout[-2000:])
    assert check["measured"]["analysis_settings"]["max_order"] == 23
    refused = tests["test_angle_reference"]
    assert refused["message"].startswith(NOT_DETERMINABLE_PREFIX + "the line-to-line back EMF")
    assert "would clip" in refused["message"] and not refused.get("capture")
