"""Per-capture operating points for foreign captures (issue 23 item 5): the manifest, FILE@A[,DEG],
and errors that name the real problem."""

import math

import numpy as np
import pytest

from hil.capture import Capture
from hil.cli import main
from hil.diagnosis.manifest import ADDITION_KEYS, parse_capture_argument, parse_manifest
from hil.errors import InputError

POLE_PAIRS = 2


def _write_csv(path, *, speed_rpm=500.0, revolutions=6, torque=None, angle_name="theta_m_rad",
               extra=None):
    """A CSV export: time, torque with an order-2 ripple, mechanical angle."""
    rate = 20_000.0
    t = np.arange(int(revolutions * 60.0 / speed_rpm * rate)) / rate
    theta = 2 * math.pi * speed_rpm / 60.0 * t
    tau = 1.0 + 0.01 * np.sin(2 * theta) + 0.004 * np.cos(4 * theta) if torque is None \
        else torque(t, theta)
    columns = {"time_s": t, "torque_nm": tau}
    if angle_name:
        columns[angle_name] = theta
    columns.update(extra(t, theta) if extra else {})
    header = ",".join(columns)
    rows = np.column_stack(list(columns.values()))
    np.savetxt(path, rows, delimiter=",", header=header, comments="", fmt="%.10g")
    return path


def _err(capsys):
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    return err[0]


def test_manifest_gives_each_capture_its_operating_point_and_the_drive(tmp_path):
    text = """
[drive]
pole_pairs = 3
emf_a_rising_zero_elec_deg = 180.0
current_loop_bandwidth_hz = 1000.0
current_loop_design = "discrete"
current_loop_decoupling = true

[motor]
phase_resistance_ohm = 0.1

[[capture]]
file = "a.csv"
current_a = 20.0
current_angle_deg = 15.0
torque_column = "tau"
angle_kind = "elec"

[[capture]]
file = "sub/b.csv"
current_a = 10.0
addition_ia_offset_a = 0.05
"""
    manifest = parse_manifest(text, tmp_path / "m.toml")
    assert manifest.pole_pairs == 3 and manifest.emf_a_rising_zero_elec_deg == 180.0
    assert manifest.drive["current_loop_design"] == "discrete"
    assert manifest.motor == {"phase_resistance_ohm": 0.1}
    a, b = manifest.captures
    assert a.path == tmp_path / "a.csv" and b.path == tmp_path / "sub" / "b.csv"
    assert a.operating_point["current_a"] == 20.0
    assert a.operating_point["current_angle_rad"] == pytest.approx(math.radians(15.0))
    assert a.import_options == {"torque_col": "tau", "angle_kind": "elec"}
    assert b.operating_point["current_a"] == 10.0 and "current_angle_rad" not in b.operating_point
    assert b.operating_point["addition_ia_offset_a"] == 0.05
    assert all(a.operating_point[key] == 0.0 for key in ADDITION_KEYS)


@pytest.mark.parametrize("text, words", [
    ('[[capture]]\nfile = "a.csv"\ncurent_a = 20.0\n', ["'curent_a'", "allowed:", "current_a"]),
    ('[drive]\npole_pair = 2\n[[capture]]\nfile = "a.csv"\ncurrent_a = 1.0\n',
     ["[drive]", "'pole_pair'", "pole_pairs"]),
    ('[[capture]]\nfile = "a.csv"\ncurrent_a = 0.0\n', ["current_a = 0.0", "(0, 100] A"]),
    ('[[capture]]\nfile = "a.csv"\ncurrent_a = -5\n', ["current_a = -5"]),
    ('[[capture]]\nfile = "a.csv"\n', ["current_a", "required"]),
    ('[[capture]]\nfile = "a.csv"\ncurrent_a = 2.0\n[[capture]]\nfile = "./a.csv"\n'
     'current_a = 3.0\n', ["listed twice"]),
    ('[drive]\ncurrent_loop_design = "pi"\n[[capture]]\nfile = "a.csv"\ncurrent_a = 1.0\n',
     ["continuous, discrete", "unknown"]),
    ('[drive]\npole_pairs = 2\n', ["no [[capture]]"]),
])
def test_manifest_errors_name_the_key(tmp_path, text, words):
    with pytest.raises(InputError) as caught:
        parse_manifest(text, tmp_path / "m.toml")
    for word in words:
        assert word in str(caught.value)


def test_file_at_current_and_angle():
    entry = parse_capture_argument("x.csv@20,15")
    assert str(entry.path) == "x.csv" and entry.operating_point["current_a"] == 20.0
    assert entry.operating_point["current_angle_rad"] == pytest.approx(math.radians(15.0))
    assert "current_a" not in parse_capture_argument("x.csv").operating_point
    for bad in ("x.csv@", "x.csv@abc", "x.csv@1,2,3", "x.csv@0", "x.csv@-3,0"):
        with pytest.raises(InputError):
            parse_capture_argument(bad)


def test_cli_foreign_captures_at_two_currents(tmp_path, capsys):
    _write_csv(tmp_path / "c20.csv")
    _write_csv(tmp_path / "c10.csv", speed_rpm=1000.0, revolutions=8)
    (tmp_path / "m.toml").write_text(
        '[drive]\npole_pairs = 2\nemf_a_rising_zero_elec_deg = 0.0\npwm_frequency_hz = 16000.0\n'
        'dead_time_bound_s = 2e-6\ncurrent_loop_bandwidth_hz = 900.0\n'
        '[[capture]]\nfile = "c20.csv"\ncurrent_a = 20.0\n'
        '[[capture]]\nfile = "c10.csv"\ncurrent_a = 10.0\ncurrent_angle_deg = 10.0\n')
    assert main(["diagnose", "--manifest", str(tmp_path / "m.toml"), "--json"]) == 0
    import json

    data = json.loads(capsys.readouterr().out)
    points = {p["label"]: p for p in data["operating_points"]}
    assert points["c20"]["current_a"] == 20.0 and points["c10"]["current_a"] == 10.0
    assert points["c10"]["current_angle_rad"] == pytest.approx(math.radians(10.0))
    assert points["c10"]["speed_rpm"] == pytest.approx(1000.0, rel=1e-3)
    assert data["setup"]["pwm_frequency_hz"] == 16000.0
    assert data["setup"]["dead_time_bound_s"] == 2e-6
    assert data["setup"]["current_loop_bandwidth_hz"] == 900.0
    # an option overrides the manifest
    assert main(["diagnose", "--manifest", str(tmp_path / "m.toml"), "--json",
                 "--pwm-frequency-hz", "20000", "--loop-bandwidth-hz", "1500"]) == 0
    setup = json.loads(capsys.readouterr().out)["setup"]
    assert setup["pwm_frequency_hz"] == 20000.0 and setup["current_loop_bandwidth_hz"] == 1500.0
    # the same two on the command line
    assert main(["diagnose", f"{tmp_path / 'c20.csv'}@20", f"{tmp_path / 'c10.csv'}@10,10",
                 "--pole-pairs", "2", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert sorted(p["current_a"] for p in data["operating_points"]) == [10.0, 20.0]


def test_cli_errors_name_the_real_problem(tmp_path, capsys):
    good = _write_csv(tmp_path / "good.csv")
    # NaN torque: which column, how many, where
    def gappy(t, theta):
        tau = 1.0 + 0.01 * np.sin(2 * theta)
        tau[100:103] = np.nan
        return tau
    _write_csv(tmp_path / "nan.csv", torque=gappy)
    assert main(["diagnose", f"{tmp_path / 'nan.csv'}@20", "--pole-pairs", "2"]) == 2
    err = _err(capsys)
    assert "torque_nm" in err and "3 NaN" in err and "sample 100" in err
    assert "--current-a" not in err
    # no angle column
    _write_csv(tmp_path / "noangle.csv", angle_name=None)
    assert main(["diagnose", f"{tmp_path / 'noangle.csv'}@20", "--pole-pairs", "2"]) == 2
    err = _err(capsys)
    assert "no rotor-angle column" in err and "angle_column" in err and "--current-a" not in err
    # no torque column
    np.savetxt(tmp_path / "notorque.csv", np.ones((10, 2)), delimiter=",", header="time_s,x",
               comments="")
    assert main(["diagnose", f"{tmp_path / 'notorque.csv'}@20", "--pole-pairs", "2"]) == 2
    assert "no torque column" in _err(capsys)
    # a file given twice
    assert main(["diagnose", f"{good}@20", f"{good}@10", "--pole-pairs", "2"]) == 2
    assert "listed twice" in _err(capsys)
    # an imported capture without its current
    assert main(["diagnose", str(good), "--pole-pairs", "2"]) == 2
    err = _err(capsys)
    assert "imported capture carries no operating point" in err and "@CURRENT_A" in err
    # a ripple-hil capture copied out of its record
    t = np.arange(4000) / 2000.0
    copied = Capture(channels={"time_s": t, "torque_nm": np.ones_like(t),
                               "rotor_angle_mech_rad": 2 * np.pi * t},
                     meta={"pole_pairs": 2, "test_id": "TP-1/diagnosis/p3"})
    copied.save(tmp_path / "copied.npz")
    assert main(["diagnose", str(tmp_path / "copied.npz")]) == 2
    err = _err(capsys)
    assert "copied out of its record" in err and "record.json" in err
    assert "copied.npz@CURRENT_A" in err


def test_additions_reach_the_operating_point(tmp_path):
    """The manifest's known additions land in the capture's operating point (shared contract:
    the dict spectra_from_captures and hil.diagnosis.additions take)."""
    from argparse import Namespace

    from hil.commands.diagnose import _load
    from hil.diagnosis.manifest import load_manifest

    _write_csv(tmp_path / "c.csv")
    (tmp_path / "m.toml").write_text(
        '[drive]\npole_pairs = 2\n[[capture]]\nfile = "c.csv"\ncurrent_a = 20.0\n'
        'addition_ib_offset_a = 0.1\n')
    manifest = load_manifest(tmp_path / "m.toml")
    args = Namespace(pole_pairs=None, bench=None, current_a=None, current_angle_deg=None)
    capture, record, op = _load(manifest.captures[0], args, manifest)
    assert record is None and op["current_a"] == 20.0 and op["addition_ib_offset_a"] == 0.1
    assert op["addition_ia_offset_a"] == 0.0 and "addition" not in capture.meta
