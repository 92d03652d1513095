"""``hil analyze`` on captures from other DAQs: CSV and .npz exports with named columns in their
own units give the same figures as the same signals in a ripple-hil capture (issue 12 item 5)."""

import json
import math

import numpy as np
import pytest

from hil.capture import Capture
from hil.capture_import import import_capture
from hil.cli import main

POLE_PAIRS = 2
ELECTRICAL_HZ = 30.0


def signals():
    """0.5 s at 10 kS/s: 0.8 N·m with order-6 (1.5 %) and order-36 ripple; angle wrapped."""
    time_s = np.arange(5000) / 10_000.0
    elec = 2 * math.pi * ELECTRICAL_HZ * time_s
    torque = 0.8 + 0.012 * np.sin(6 * elec + 0.4) + 0.002 * np.sin(36 * elec)
    return time_s, torque, np.mod(elec / POLE_PAIRS, 2 * math.pi)


def analyze_json(capsys, *argv):
    code = main(["analyze", *argv, "--json", "--order", "6"])
    out, err = capsys.readouterr()
    assert code == 0, err
    return json.loads(out)


@pytest.fixture
def native(tmp_path, capsys):
    time_s, torque, mech = signals()
    path = tmp_path / "native.npz"
    Capture({"time_s": time_s, "torque_nm": torque, "rotor_angle_mech_rad": mech},
            meta={"pole_pairs": POLE_PAIRS}).save(path)
    return analyze_json(capsys, str(path))


def same_figures(imported, native):
    for key in ("pk_pk_pu", "mean_torque_nm", "named_amplitude_nm", "revolutions"):
        assert imported[key] == pytest.approx(native[key], rel=1e-9), key


def test_csv_in_scope_units(tmp_path, capsys, native):
    time_s, torque, mech = signals()
    path = tmp_path / "scope.csv"
    rows = "\n".join(f"{1e3 * t:.9f};{1e3 * q:.9f};{math.degrees(a):.9f}"
                     for t, q, a in zip(time_s, torque, mech))
    path.write_text("# exported by a scope\nTime [ms];Torque [mNm];Angle [deg]\n" + rows + "\n")
    imported = analyze_json(capsys, str(path), "--time-col", "Time [ms]", "--time-unit", "ms",
                            "--torque-col", "Torque [mNm]", "--torque-unit", "mnm",
                            "--angle-col", "Angle [deg]", "--angle-unit", "deg",
                            "--pole-pairs", str(POLE_PAIRS))
    same_figures(imported, native)


def test_npz_with_electrical_angle(tmp_path, capsys, native):
    time_s, torque, mech = signals()
    path = tmp_path / "daq.npz"
    np.savez(path, t=time_s, tq=torque, theta_e=np.mod(mech * POLE_PAIRS, 2 * math.pi))
    imported = analyze_json(capsys, str(path), "--time-col", "t", "--torque-col", "tq",
                            "--angle-col", "theta_e", "--angle-kind", "elec",
                            "--pole-pairs", str(POLE_PAIRS))
    same_figures(imported, native)


def test_speed_column_instead_of_an_angle(tmp_path):
    time_s, torque, _ = signals()
    path = tmp_path / "speed.csv"
    speed_rpm = np.full(time_s.size, 60.0 * ELECTRICAL_HZ / POLE_PAIRS)
    path.write_text("t,T,n\n" + "\n".join(f"{a},{b},{c}" for a, b, c in
                                          zip(time_s, torque, speed_rpm)))
    capture = import_capture(path, time_col="t", torque_col="T", speed_col="n",
                             pole_pairs=POLE_PAIRS)
    assert set(capture.channels) == {"time_s", "torque_nm", "speed_rpm"}
    assert capture.meta["imported"]["speed"] == "n [rpm]"


@pytest.mark.parametrize("argv,message", [
    (["--time-col", "t", "--torque-col", "T", "--angle-col", "nope", "--pole-pairs", "2"],
     "no such column (the file has: T, n, t)"),
    (["--time-col", "t", "--torque-col", "T", "--pole-pairs", "2"], "--angle-col"),
    (["--time-col", "t", "--torque-col", "T", "--angle-col", "n"], "--pole-pairs"),
    (["--torque-col", "T", "--angle-col", "n", "--pole-pairs", "2"], "--time-col"),
])
def test_import_errors_are_one_line(tmp_path, capsys, argv, message):
    path = tmp_path / "x.csv"
    path.write_text("t,T,n\n0,1,2\n0.1,1,2\n")
    code = main(["analyze", str(path), *argv])
    out, err = capsys.readouterr()
    assert code == 2 and out == "" and err.count("\n") == 1 and message in err
