"""Bench-file loading: shipped examples, round trip, and the errors a bench engineer meets."""

from __future__ import annotations

import hashlib
import math
import tomllib
from datetime import date
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hil.config import (BenchConfig, default_sim_bench, example_bench_path, load_bench)
from hil.errors import InputError
from hil.motor import TABLE_I

REAL = example_bench_path("real-bench")


def real_dict() -> dict:
    return tomllib.loads(REAL.read_text())


def test_shipped_benches_load_with_their_file_hash():
    sim = default_sim_bench()
    assert sim.simulated and sim.motor == TABLE_I
    assert sim.sha256 == hashlib.sha256(example_bench_path("sim-bench").read_bytes()).hexdigest()
    real = load_bench(REAL)
    assert not real.simulated
    assert real.drive.interface == "pcan" and real.drive.channel == "PCAN_USBBUS1"
    assert (real.daq.transport, real.daq.host, real.daq.port) == ("tcp", "192.168.10.20", 502)
    assert (real.torque.serial_port, real.torque.dialect) == ("/dev/ttyUSB0", "magtrol")
    assert real.instrument("torque").calibration_due == date(2027, 3, 2)
    assert math.isclose(real.operating_point.current_angle_rad, 0.0)


def test_to_dict_round_trips():
    for bench in (default_sim_bench(), load_bench(REAL)):
        again = BenchConfig.from_dict(bench.to_dict(), source="round trip")
        assert again == bench
        assert again.to_dict() == bench.to_dict()


def test_sim_bench_addresses_filled_in_later():
    bench = default_sim_bench()
    assert bench.daq.port is None and bench.torque.serial_port is None
    filled = bench.with_overrides({"daq": {"host": "127.0.0.1", "port": 15020},
                                   "drive": {"channel": "bench-1"},
                                   "torque": {"serial_port": "/dev/pts/7"}})
    assert (filled.daq.host, filled.daq.port, filled.drive.channel) == ("127.0.0.1", 15020,
                                                                      "bench-1")
    assert filled.sha256 == bench.sha256
    with pytest.raises(InputError, match=r"daq\.port = 70000 is out of range; allowed 1\.\.65535"):
        bench.with_overrides({"daq": {"port": 70000}})


@pytest.mark.parametrize("change, message", [
    ({"daq": {"prot": 502}}, r"unknown key 'daq\.prot' \(did you mean 'port'\?\)"),
    ({"limitz": {}}, r"unknown key 'limitz' \(did you mean 'limits'\?\)"),
    ({"drive": {"interface": "pcann"}}, r"drive\.interface = 'pcann' is not allowed; allowed:.*'pcan'"),
    ({"drive": {"node_id": 0}}, r"drive\.node_id = 0 is out of range; allowed 1\.\.127"),
    ({"drive": {"node_id": 5.0}}, r"drive\.node_id = 5\.0 must be an integer"),
    ({"drive": {"bitrate": 300000}}, r"drive\.bitrate = 300000 is not allowed"),
    ({"daq": {"transport": "udp"}}, r"daq\.transport = 'udp' is not allowed; allowed: 'tcp', 'rtu'"),
    ({"daq": {"serial_port": "/dev/ttyS0"}}, r"daq\.serial_port is only used with transport = 'rtu'"),
    ({"daq": {"transport": "rtu", "host": None, "port": None, "unit_id": 1}},
     r"daq\.serial_port is required with transport = 'rtu'"),
    ({"torque": {"dialect": "hbm"}}, r"torque\.dialect = 'hbm' is not allowed; allowed: 'magtrol', 'himmelstein'"),
    ({"torque": {"full_scale_nm": "5"}}, r"torque\.full_scale_nm = '5' must be a finite number"),
    ({"limits": {"current_a": 150.0}}, r"limits\.current_a = 150\.0 is out of range; allowed 0\.1\.\.100"),
    ({"operating_point": {"current_a": 70.0}}, r"operating_point\.current_a = 70\.0 exceeds limits\.current_a = 60"),
    ({"operating_point": {"speed_rpm": -2600.0}}, r"operating_point\.speed_rpm = -2600\.0 exceeds limits\.speed_rpm"),
    ({"motor": {"pole_count": 5}}, r"motor\.pole_count must be an even number"),
    ({"motor": {"ke_v_s_per_rad": -1.0}}, r"motor\.ke_v_s_per_rad must be > 0"),
    ({"simulated": "yes"}, r"simulated = 'yes' must be true or false"),
    ({"drive": {"eds": "missing.eds"}}, r"drive\.eds = 'missing\.eds': no such file"),
])
def test_bad_values_name_the_key_and_the_allowed_range(change, message):
    d = real_dict()
    for section, values in change.items():
        if isinstance(values, dict):
            d.setdefault(section, {}).update(values)
            d[section] = {k: v for k, v in d[section].items() if v is not None}
        else:
            d[section] = values
    with pytest.raises(InputError, match=message):
        BenchConfig.from_dict(d, source="bench.toml", base_dir=REAL.parent)


def test_real_bench_requires_addresses_limits_and_torque_instrument():
    d = real_dict()
    del d["torque"]["serial_port"]
    with pytest.raises(InputError, match=r"torque\.serial_port is required on a real bench"):
        BenchConfig.from_dict(d)
    d = real_dict()
    del d["limits"]
    with pytest.raises(InputError, match=r"limits\.current_a is required on a real bench"):
        BenchConfig.from_dict(d)
    d = real_dict()
    d["instrument"] = [e for e in d["instrument"] if e["role"] != "torque"]
    with pytest.raises(InputError, match=r'needs an \[\[instrument\]\] with role = "torque"'):
        BenchConfig.from_dict(d)


@pytest.mark.parametrize("change, message", [
    ({"role": "scope"}, r"instrument\[2\]\.role = 'scope' is not allowed"),
    ({"serial_number": None}, r"instrument\[2\]\.serial_number is required"),
    ({"calibration_due": "next year"}, r"instrument\[2\]\.calibration_due = 'next year' must be a date"),
    ({"calibration_due": date(2025, 1, 1)}, r"calibration_due = 2025-01-01 is before calibration_date"),
    ({"accuracy_class": "very good"}, r"instrument\[2\]\.accuracy_class = 'very good' is not a percentage"),
    ({"serial": "x"}, r"unknown key 'instrument\[2\]\.serial' \(did you mean 'serial_number'\?\)"),
    ({"role": "drive"}, r"role 'drive' appears 2 times"),
])
def test_instrument_entries_are_checked(change, message):
    d = real_dict()
    entry = d["instrument"][2]
    assert entry["role"] == "torque"
    entry.update(change)
    d["instrument"][2] = {k: v for k, v in entry.items() if v is not None}
    with pytest.raises(InputError, match=message):
        BenchConfig.from_dict(d)


def test_calibration_problems_past_due_future_and_missing():
    bench = load_bench(REAL)
    assert bench.calibration_problems(date(2026, 6, 1)) == []
    late = bench.calibration_problems(date(2027, 2, 1))
    assert late == ["daq Modbus DAQ 16-bit, 8 channels s/n DAQ-55871: calibration was due "
                    "2027-01-15 (today is 2027-02-01)"]
    early = bench.calibration_problems(date(2026, 1, 20))
    assert any("TM305-7781" in p and "in the future" in p for p in early)
    d = real_dict()
    del d["instrument"][3]["calibration_due"]
    problems = BenchConfig.from_dict(d).calibration_problems(date(2026, 6, 1))
    assert problems == ["dyno Magtrol HD-715 hysteresis dynamometer s/n HD715-3310: "
                        "calibration_due not stated"]
    # simulated instruments carry no certificate: missing dates are not a problem there
    assert default_sim_bench().calibration_problems(date(2026, 6, 1)) == []


def test_uncertainty_inputs_read_the_instrument_entries():
    bench = load_bench(REAL)
    inputs = bench.uncertainty_inputs()
    assert inputs == {"transducer_accuracy_class_pct": pytest.approx(0.1),
                      "transducer_full_scale_nm": pytest.approx(5.0),
                      "daq_lsb_nm": pytest.approx(0.0002)}  # the DAQ's, not the sensor's
    built = bench.instrument_uncertainty()
    assert built.transducer_limit_nm == pytest.approx(0.005)   # 0.1 % of 5 N*m
    assert built.lsb_nm == pytest.approx(0.0002)
    d = real_dict()
    d["instrument"][1]["resolution"] = "16 bit"
    d["instrument"][2]["resolution"] = "1 mN*m"
    assert BenchConfig.from_dict(d).uncertainty_inputs()["daq_lsb_nm"] == pytest.approx(0.001)
    del d["instrument"][2]["accuracy_class"]
    assert BenchConfig.from_dict(d).uncertainty_inputs()["transducer_accuracy_class_pct"] == 0.0


def test_file_errors_are_input_errors(tmp_path: Path):
    with pytest.raises(InputError, match="cannot be read"):
        load_bench(tmp_path / "none.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[daq]\nport = \n")
    with pytest.raises(InputError, match="is not valid TOML"):
        load_bench(bad)
    # a relative EDS path resolves from the bench file's folder
    (tmp_path / "my.eds").write_text("[FileInfo]\n")
    good = tmp_path / "bench.toml"
    good.write_text(REAL.read_text().replace('# eds = "drive.eds"', 'eds = "my.eds"'))
    assert load_bench(good).drive.eds == tmp_path / "my.eds"


def test_no_code_is_evaluated(tmp_path: Path):
    path = tmp_path / "evil.toml"
    path.write_text('simulated = true\n[lab]\nname = "__import__(\'os\').system(\'false\')"\n')
    bench = load_bench(path)
    assert bench.lab.name == "__import__('os').system('false')"


@settings(max_examples=25, deadline=None)
@given(port=st.integers(1, 65535), node_id=st.integers(1, 127),
       current=st.floats(0.1, 60.0), speed=st.floats(-2500.0, 2500.0),
       angle=st.floats(-90.0, 90.0), bad_key=st.text(min_size=1, max_size=12))
def test_valid_values_round_trip_and_any_unknown_key_is_refused(port, node_id, current, speed,
                                                                angle, bad_key):
    d = real_dict()
    d["daq"]["port"] = port
    d["drive"]["node_id"] = node_id
    d["operating_point"] = {"current_a": current, "speed_rpm": speed, "current_angle_deg": angle}
    bench = BenchConfig.from_dict(d)
    assert BenchConfig.from_dict(bench.to_dict()) == bench
    assert (bench.daq.port, bench.drive.node_id) == (port, node_id)
    assert bench.operating_point.current_angle_rad == pytest.approx(math.radians(angle))
    if bad_key not in d["daq"] and bad_key not in ("host", "port", "unit_id", "timeout_s",
                                                   "transport", "serial_port", "baudrate",
                                                   "register_map"):
        d["daq"][bad_key] = 1
        with pytest.raises(InputError, match="unknown key"):
            BenchConfig.from_dict(d)
