"""``hil analyze``: output, JSON, and one-line errors for bad captures."""

from __future__ import annotations

import json

import numpy as np
import pytest

from analysis_synthetic import TWO_PI, ripple, speed_profile_angle
from hil.capture import Capture
from hil.cli import main

POLE_PAIRS = 2


def _capture(path, *, duration_s=0.5, torque_edit=None, time_edit=None, angle=None):
    time_s = np.arange(int(10_000 * duration_s)) / 10_000.0
    electrical = speed_profile_angle(time_s, electrical_hz=30.0, variation=0.03)
    torque = ripple(electrical, 0.8, {6: (0.012, 0.4), 36: (0.002, 0.0)})
    if torque_edit:
        torque_edit(torque)
    if time_edit:
        time_edit(time_s)
    mech = np.mod(electrical / POLE_PAIRS, TWO_PI) if angle is None else angle(time_s)
    Capture({"time_s": time_s, "torque_nm": torque, "rotor_angle_mech_rad": mech},
            meta={"pole_pairs": POLE_PAIRS, "source": "synthetic"}).save(path)
    return path


def test_text_output_lists_metrics_orders_and_budget(tmp_path, capsys):
    path = _capture(tmp_path / "c.npz")
    assert main(["analyze", str(path), "--order", "6", "--max-order", "48",
                 "--transducer-class-pct", "0.1", "--transducer-full-scale-nm", "5",
                 "--daq-lsb-nm", "0.001", "--rated-torque-nm", "2"]) == 0
    out = capsys.readouterr().out
    grid = np.linspace(0.0, TWO_PI, 100_000)
    expected = np.ptp(ripple(grid, 0.8, {6: (0.012, 0.4), 36: (0.002, 0.0)}))
    line = next(row for row in out.splitlines() if row.startswith("pk-pk (sync average)"))
    assert float(line.split()[3]) == pytest.approx(expected, rel=0.005)
    assert "dominant order       6" in out
    assert "type B: transducer accuracy class, on mean" in out
    assert "expanded U" in out and "pk-pk of rated" in out
    table = out.split("AC power")[1].splitlines()
    assert table[1].split()[0] == "6" and table[2].split()[0] == "36"


def test_json_output_is_one_object(tmp_path, capsys):
    path = _capture(tmp_path / "c.npz")
    assert main(["analyze", str(path), "--order", "36", "--json", "--top", "2"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["named_order"] == 36
    assert data["named_amplitude_nm"] == pytest.approx(0.002, rel=0.005)
    assert data["pk_pk_pu"] == pytest.approx(data["pk_pk_nm"] / data["mean_torque_nm"])
    assert [row["order"] for row in data["top_orders"]] == [6, 36]
    assert data["uncertainty"]["coverage_factor"] == 2.0


def _set_nan(torque):
    torque[100] = np.nan


def _time_backwards(time_s):
    time_s[50] = time_s[40]


@pytest.mark.parametrize("kwargs,message", [
    ({"torque_edit": _set_nan}, "non-finite"),
    ({"duration_s": 0.02}, "at least one whole revolution"),
    ({"time_edit": _time_backwards}, "not strictly increasing"),
    ({"angle": lambda t: np.full_like(t, 1.0)}, "never advances"),
    ({"angle": lambda t: np.sin(TWO_PI * 3 * t)}, "runs backwards"),
])
def test_bad_capture_gives_one_line_error(tmp_path, capsys, kwargs, message):
    path = _capture(tmp_path / "bad.npz", **kwargs)
    assert main(["analyze", str(path)]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert message in captured.err
    assert captured.err.count("\n") == 1 and "Traceback" not in captured.err


def test_missing_file_and_bad_option(tmp_path, capsys):
    assert main(["analyze", str(tmp_path / "absent.npz")]) == 2
    assert "does not exist" in capsys.readouterr().err
    path = _capture(tmp_path / "c.npz")
    assert main(["analyze", str(path), "--max-order", "0"]) == 2
    assert "--max-order" in capsys.readouterr().err  # the option, not a Python name


def test_json_of_a_single_revolution_has_null_uncertainty(tmp_path, capsys):
    path = _capture(tmp_path / "one.npz", duration_s=0.06)       # 1.8 electrical revolutions
    assert main(["analyze", str(path), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["revolutions"] == 1
    assert data["uncertainty"]["expanded_pu"] is None
    assert data["top_orders"][0]["amplitude_u_nm"] is None
