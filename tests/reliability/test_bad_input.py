"""Bad input: bench files, injections, corrupted capture files and records. Each must give a
clear error (naming the key / knob / file and what is allowed) and change nothing on the bench.
"""

from __future__ import annotations

import datetime as dt
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest
import tomli_w

from ripple_hil_drivers.errors import InjectionRangeError
from ripple_hil_fixtures.session import CalibrationGateError, HilSession
from hil.cli import main as hil_main
from hil.config import example_bench_path, load_bench
from hil.errors import InputError
from hil.measurement import measure_point
from hil.sim import DriveTwin
from integration.test_safety import assert_safe

from .faults import copy_record, point

HIL = [sys.executable, "-m", "hil"]
TODAY = dt.date(2026, 11, 21)


def bench_table(name: str = "sim-bench") -> dict:
    return tomllib.loads(example_bench_path(name).read_text())


def write_bench(path: Path, table: dict) -> Path:
    path.write_text(tomli_w.dumps(table))
    return path


def edited(name: str, section: str, key: str, value) -> dict:
    """A shipped bench file with one key set (value None: the key removed)."""
    table = bench_table(name)
    target = table[section][0] if section == "instrument" else table.setdefault(section, {})
    if value is None:
        target.pop(key, None)
    else:
        target[key] = value
    return table


# ------------------------------------------------------------------------------ bench files
BAD_BENCHES = [
    # (id, shipped file, section, key, value, words the message must contain)
    ("missing-channel", "real-bench", "drive", "channel", None,
     ["drive.channel is required"]),
    ("missing-serial", "sim-bench", "instrument", "serial_number", None,
     ["instrument[0].serial_number is required"]),
    ("missing-full-scale", "real-bench", "torque", "full_scale_nm", None,
     ["torque.full_scale_nm is required", "0.01..10000"]),
    ("current-as-text", "sim-bench", "limits", "current_a", "sixty",
     ["limits.current_a", "'sixty'", "finite number", "0.1..100"]),
    ("node-id-float", "sim-bench", "drive", "node_id", 1.5,
     ["drive.node_id", "must be an integer", "1..127"]),
    ("simulated-as-text", "sim-bench", None, "simulated", "yes",
     ["simulated = 'yes'", "true or false"]),
    ("current-limit-too-high", "sim-bench", "limits", "current_a", 500.0,
     ["limits.current_a = 500.0", "out of range", "0.1..100"]),
    ("speed-limit-zero", "sim-bench", "limits", "speed_rpm", 0.0,
     ["limits.speed_rpm", "1..3000"]),
    ("speed-limit-nan", "sim-bench", "limits", "speed_rpm", float("nan"),
     ["limits.speed_rpm", "finite number"]),
    ("operating-point-over-limit", "sim-bench", "operating_point", "current_a", 70.0,
     ["operating_point.current_a = 70.0 exceeds limits.current_a"]),
    ("unknown-can-interface", "real-bench", "drive", "interface", "warp-drive",
     ["drive.interface = 'warp-drive' is not allowed", "'socketcan'"]),
    ("unknown-dialect", "sim-bench", "torque", "dialect", "hbm",
     ["torque.dialect = 'hbm'", "'himmelstein'"]),
    ("daq-port-out-of-range", "real-bench", "daq", "port", 70000,
     ["daq.port = 70000", "1..65535"]),
    ("bad-bitrate", "sim-bench", "drive", "bitrate", 123456,
     ["drive.bitrate = 123456", "500000"]),
    ("typo-key", "sim-bench", "limits", "curent_a", 10.0,
     ["unknown key 'limits.curent_a'", "did you mean 'current_a'"]),
    ("negative-resistance", "sim-bench", "motor", "phase_resistance_ohm", -0.1,
     ["phase_resistance_ohm", "> 0"]),
    ("bad-date", "sim-bench", "instrument", "calibration_due", "next year",
     ["instrument[0].calibration_due", "a date like"]),
    ("missing-eds-file", "sim-bench", "drive", "eds", "no-such.eds",
     ["drive.eds", "no such file"]),
]


@pytest.mark.parametrize("name, section, key, value, words",
                         [case[1:] for case in BAD_BENCHES], ids=[c[0] for c in BAD_BENCHES])
def test_bad_bench_file_is_refused_naming_the_key(tmp_path, name, section, key, value, words):
    if section is None:
        table = bench_table(name) | {key: value}
    else:
        table = edited(name, section, key, value)
    path = write_bench(tmp_path / "bench.toml", table)
    with pytest.raises(InputError) as caught:
        load_bench(path)
    message = str(caught.value)
    assert message.startswith(str(path)) and "\n" not in message
    for word in words:
        assert word in message, (word, message)


@pytest.mark.parametrize("content, words", [
    (b"simulated = true\n[limits\ncurrent_a = 1\n", "is not valid TOML"),
    (b"simulated = true\n# \xff\xfe\n", "is not UTF-8 text"),
    (None, "cannot be read"),
])
def test_unreadable_bench_file(tmp_path, content, words):
    path = tmp_path / "bench.toml"
    if content is not None:
        path.write_bytes(content)
    with pytest.raises(InputError, match=words):
        load_bench(path)


def test_bad_bench_file_stops_the_run_before_anything_starts(tmp_path):
    """pytest with a bad --hil-bench: one usage error, no test run, no record, no instrument."""
    path = write_bench(tmp_path / "bench.toml", edited("sim-bench", "limits", "current_a", 500.0))
    done = subprocess.run([sys.executable, "-m", "pytest", "-p", "no:cacheprovider",
                           str(Path(__import__("ripple_hil_testplans").__file__).parent / "test_baseline.py"),
                           "--hil-bench", str(path), "--hil-record", str(tmp_path / "records")],
                          capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert done.returncode == 4, done.stdout[-2000:]          # pytest's usage error
    assert "limits.current_a = 500.0 is out of range; allowed 0.1..100" in done.stderr
    assert "Traceback" not in done.stdout + done.stderr
    assert not (tmp_path / "records").exists()


def test_hil_run_with_a_bad_bench_file_exits_2(tmp_path):
    path = write_bench(tmp_path / "bench.toml", edited("sim-bench", "limits", "current_a", 500.0))
    done = subprocess.run(HIL + ["run", "--bench", str(path), "--source", "baseline",
                                 "--no-report", "--record-dir", str(tmp_path / "records")],
                          capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert not (tmp_path / "records").exists()
    assert done.returncode == 2 and done.stderr.startswith("hil run: error:"), done.stderr
    assert done.stderr.count("\n") == 1 and "limits.current_a" in done.stderr


def test_expired_calibration_refuses_to_open_the_bench(tmp_path, monkeypatch):
    table = edited("sim-bench", "instrument", "calibration_date", dt.date(2025, 1, 10))
    table["instrument"][0]["calibration_due"] = dt.date(2026, 1, 10)
    path = write_bench(tmp_path / "bench.toml", table)
    opened = []
    monkeypatch.setattr("hil.bench.Bench.open", lambda *a, **k: opened.append(a))
    session = HilSession(bench_path=str(path), record_root=tmp_path / "records",
                         report_path=None, calibration_override=None, operator=None, seed=0,
                         today=TODAY)
    for _ in range(2):                  # every test of the session fails the same way
        with pytest.raises(CalibrationGateError) as caught:
            session.open_bench()
    message = str(caught.value)
    assert "calibration was due 2026-01-10 (today is 2026-11-21)" in message
    assert "--hil-allow-expired-calibration" in message
    assert opened == [] and not (tmp_path / "records").exists()
    # an override without a name is refused too
    session = HilSession(bench_path=str(path), record_root=tmp_path / "records",
                         report_path=None, calibration_override="urgent", operator=None, seed=0,
                         today=TODAY)
    with pytest.raises(CalibrationGateError, match="--hil-operator"):
        session.open_bench()
    assert opened == []


# ------------------------------------------------------------------------------ injections
@pytest.mark.parametrize("knob, value, words", [
    ("ia_offset_a", 25.0, ["ia_offset_a"]),
    ("ib_gain_error_pu", -0.5, ["ib_gain_error_pu"]),
    ("encoder_decimation", 5000, ["encoder_decimation"]),
    ("dead_time_s", 20e-6, ["dead_time_s"]),
    ("pwm_frequency_hz", 1000.0, ["pwm_frequency_hz"]),
    ("current_angle_rad", 2.0, ["current_angle_rad"]),
    ("ia_offset_a", float("nan"), ["ia_offset_a"]),
])
def test_injection_outside_its_range_changes_nothing(sim_bench, run_record, knob, value, words):
    """Refused by the driver from the EDS limits before any SDO is sent; a plan with it is
    refused before the drive is energised."""
    twin = sim_bench.simulated.twin
    with pytest.raises(InjectionRangeError) as caught:
        sim_bench.drive.set_injection(ib_offset_a=0.3, **{knob: value})
    message = str(caught.value)
    assert caught.value.instrument == "drive" and ".." in message
    for word in words:
        assert word in message
    assert twin.injection == type(twin.injection)()   # ib_offset_a=0.3 was not sent either
    plan = point(current_angle_rad=value) if knob == "current_angle_rad" \
        else point(injection={knob: value})
    with pytest.raises(InjectionRangeError):
        measure_point(sim_bench, run_record, f"bad-{knob}", plan)
    assert twin.enabled is False and twin.time_s == 0.0, "the drive was energised"
    assert_safe(sim_bench)
    assert run_record.tests[-1]["outcome"] == "error"


def test_current_angle_belongs_to_the_plan_not_the_injection():
    with pytest.raises(InputError, match="PointPlan.current_angle_rad"):
        point(injection={"current_angle_rad": 0.1})


def test_unknown_knob_and_bad_dyno_speed(sim_bench):
    with pytest.raises(InputError, match="unknown injection knob 'ia_ofset_a'"):
        sim_bench.drive.set_injection(ia_ofset_a=0.1)
    with pytest.raises(InputError, match="speed_rpm=5000"):
        sim_bench.daq.set_dyno_speed_rpm(5000.0)
    assert_safe(sim_bench)


@pytest.mark.parametrize("values, words", [
    ({"ia_offset_a": 21.0}, "ia_offset_a"),
    ({"word_length_bits": 4}, "word_length_bits"),
    ({"pwm_period_counts": 7}, "pwm_period_counts"),
    ({"no_such_knob": 1}, "no_such_knob"),
])
def test_twin_refuses_out_of_range_injections(values, words):
    twin = DriveTwin(seed=0)
    with pytest.raises(ValueError, match=words):
        twin.set_injection(**values)
    assert twin.injection == type(twin.injection)()


# ------------------------------------------------------------------------------ capture files
def _header(meta: dict | list | str = None) -> np.ndarray:
    import json
    text = meta if isinstance(meta, str) else json.dumps(
        {"units": {}, "meta": {"pole_pairs": 2}} if meta is None else meta)
    return np.frombuffer(text.encode(), dtype=np.uint8)


def _corrupt(kind: str, good: Path, target: Path) -> Path:
    data = good.read_bytes()
    ramp = np.linspace(0.0, 20.0, 1000)
    if kind == "truncated":
        target.write_bytes(data[: len(data) // 3])
    elif kind == "bit-flips":
        flipped = bytearray(data)
        for i in range(200, len(flipped), 397):
            flipped[i] ^= 0x5A
        target.write_bytes(bytes(flipped))
    elif kind == "empty":
        target.write_bytes(b"")
    elif kind == "text":
        target.write_text("time_s,torque_nm\n0,1\n")
    elif kind == "missing":
        pass
    elif kind == "header-not-json":
        np.savez(target, __header__=_header("{units"), ch_time_s=np.arange(10.0))
    elif kind == "header-a-list":
        np.savez(target, __header__=_header([1, 2]), ch_time_s=np.arange(10.0))
    elif kind == "no-header":
        np.savez(target, ch_time_s=np.arange(10.0))
    elif kind == "scalar-channel":
        np.savez(target, __header__=_header(), ch_time_s=np.float64(3.0))
    elif kind == "text-channel":
        np.savez(target, __header__=_header(), ch_time_s=np.array(["a"] * 10),
                 ch_torque_nm=np.array(["b"] * 10), ch_rotor_angle_mech_rad=np.array(["c"] * 10))
    elif kind == "nan-torque":
        np.savez(target, __header__=_header(), ch_time_s=np.arange(1000) / 1e3,
                 ch_torque_nm=np.full(1000, np.nan), ch_rotor_angle_mech_rad=ramp)
    elif kind == "lengths-differ":
        np.savez(target, __header__=_header(), ch_time_s=np.arange(1000) / 1e3,
                 ch_torque_nm=np.ones(999), ch_rotor_angle_mech_rad=ramp)
    elif kind == "bad-pole-pairs":
        np.savez(target, __header__=_header({"meta": {"pole_pairs": "two"}}),
                 ch_time_s=np.arange(1000) / 1e3, ch_torque_nm=np.ones(1000),
                 ch_rotor_angle_mech_rad=ramp)
    return target




CORRUPTIONS = ["truncated", "bit-flips", "empty", "text", "missing", "header-not-json",
               "header-a-list", "no-header", "scalar-channel", "text-channel", "nan-torque",
               "lengths-differ", "bad-pole-pairs"]


@pytest.fixture(scope="module")
def good_capture(tmp_path_factory) -> Path:
    from hil.capture import Capture

    n = 4000
    time_s = np.arange(n) / 4000.0
    angle = 2 * np.pi * 8.33 * time_s
    torque = 1.0 + 0.02 * np.cos(2 * 2 * angle)
    path = tmp_path_factory.mktemp("capture") / "good.npz"
    Capture({"time_s": time_s, "rotor_angle_mech_rad": angle, "torque_nm": torque},
            meta={"pole_pairs": 2, "sample_rate_hz": 4000.0}).save(path)
    return path


@pytest.mark.parametrize("kind", CORRUPTIONS)
def test_hil_analyze_refuses_a_corrupted_capture_on_one_line(tmp_path, capsys, good_capture,
                                                           kind):
    target = _corrupt(kind, good_capture, tmp_path / f"{kind}.npz")
    code = hil_main(["analyze", str(target)])
    captured = capsys.readouterr()
    assert code == 2, captured
    assert captured.err.startswith("hil analyze: error: ") and captured.err.count("\n") == 1
    assert captured.out == ""


def test_hil_analyze_reads_the_good_capture(capsys, good_capture):
    """The control: the file the corruptions start from is analysed (its ripple is mechanical
    order 4 = electrical order 2 with 2 pole pairs)."""
    assert hil_main(["analyze", str(good_capture), "--json"]) == 0
    import json
    result = json.loads(capsys.readouterr().out)
    assert result["dominant_order"] == 2


@pytest.mark.parametrize("damage, words", [
    ("record-json-truncated", "is not valid JSON"),
    ("record-json-wrong-format", "format"),
    ("record-json-missing", "cannot read record.json"),
    ("record-json-bad-test", "needs a test_id and an outcome"),
])
def test_hil_report_refuses_a_corrupted_record_on_one_line(small_record, tmp_path, capsys,
                                                         damage, words):
    folder = copy_record(small_record, tmp_path)
    record_json = folder / "record.json"
    text = record_json.read_text()
    if damage == "record-json-truncated":
        record_json.write_text(text[: len(text) // 2])
    elif damage == "record-json-wrong-format":
        record_json.write_text(text.replace('"ripple-hil-record/2"', '"something-else/9"'))
    elif damage == "record-json-missing":
        record_json.unlink()
    else:
        record_json.write_text(text.replace('"outcome": "passed"', '"outcome": "fine"', 1))
    code = hil_main(["report", str(folder), "-o", str(tmp_path / "r.pdf")])
    err = capsys.readouterr().err
    assert code == 2 and err.startswith("hil report: error: ") and err.count("\n") == 1, err
    assert words in err
    assert not (tmp_path / "r.pdf").exists()


@pytest.mark.parametrize("damage", [
    "capture-truncated",
    "capture-altered",
    "capture-deleted",
])
def test_hil_report_on_a_record_with_a_damaged_capture_says_so(small_record, tmp_path, capsys,
                                                               damage):
    """The record is intact, one capture is not: the report is still written, names the problem
    (its hash check fails) and says INVALID; the command exits 1 instead of dying."""
    folder = copy_record(small_record, tmp_path)
    capture = sorted((folder / "captures").glob("*.npz"))[0]
    if damage == "capture-truncated":
        capture.write_bytes(capture.read_bytes()[:300])
    elif damage == "capture-altered":
        data = bytearray(capture.read_bytes())
        data[-30] ^= 0xFF
        capture.write_bytes(bytes(data))
    else:
        capture.unlink()
    code = hil_main(["report", str(folder), "-o", str(tmp_path / "r.pdf"), "--json"])
    out = capsys.readouterr().out
    assert code == 1
    import json
    summary = json.loads(out)
    assert summary["overall"] == "INVALID"
    assert any(capture.name in problem for problem in summary["integrity_problems"]), summary
    assert (tmp_path / "r.pdf").read_bytes().startswith(b"%PDF")
