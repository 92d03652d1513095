"""``hil predict`` and ``hil budget``: JSON output, unit conversion and one-line input errors."""

import json
import math
import subprocess
import sys

import pytest

from hil.cli import main
from hil.model import OperatingPoint, predict
from hil.model.budget import invert


def run_cli(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


@pytest.mark.parametrize("argv,source,kwargs", [
    (["encoder", "--encoder-decimation", "100", "--current-angle-deg", "10"], "encoder",
     dict(encoder_decimation=100)),
    (["encoder", "--hall-mode"], "encoder", dict(hall_mode=True)),
    (["encoder", "--resolution-deg", "10"], "encoder", dict(resolution_elec_rad=math.radians(10))),
    (["word_length", "--word-length-bits", "12"], "word_length", dict(word_length_bits=12)),
    (["dc_offset", "--offset-a-pct", "1", "--offset-b-pct", "1"], "dc_offset",
     dict(offset_a_pu=0.01, offset_b_pu=0.01)),
    (["dc_offset", "--ia-offset-a", "0.3"], "dc_offset", dict(ia_offset_a=0.3)),
    (["gain_mismatch", "--ia-gain-error-pct", "1", "--ib-gain-error-pct", "-1"], "gain_mismatch",
     dict(ia_gain_error_pu=0.01, ib_gain_error_pu=-0.01)),
    (["pwm_resolution", "--pwm-period-counts", "2000"], "pwm_resolution",
     dict(pwm_period_counts=2000)),
    (["pwm_resolution", "--pwm-bits", "10"], "pwm_resolution", dict(pwm_bits=10)),
    (["pwm_switching", "--pwm-frequency-hz", "10000"], "pwm_switching",
     dict(pwm_frequency_hz=10000)),
    (["pwm_switching", "--model", "switched_torque"], "pwm_switching",
     dict(model="switched_torque")),
    (["dead_time", "--dead-time-us", "2", "--nominal-current-a", "20.78"], "dead_time",
     dict(dead_time_s=2e-6, nominal_current_a=20.78)),
    (["dead_time", "--dead-time-us", "2", "--model", "average_voltage",
      "--current-loop-bandwidth-hz", "1000"], "dead_time",
     dict(dead_time_s=2e-6, model="average_voltage", current_loop_bandwidth_hz=1000.0)),
])
def test_predict_json_matches_the_python_api(capsys, argv, source, kwargs):
    code, out, err = run_cli(capsys, "predict", *argv, "--speed-rpm", "800", "--current-a", "25",
                             "--json")
    assert code == 0 and err == ""
    data = json.loads(out)
    phi = math.radians(10) if "--current-angle-deg" in argv else 0.0
    expected = predict(source, OperatingPoint(800, 25.0, phi), **kwargs)
    assert data["pk_pk_pu"] == pytest.approx(expected.pk_pk_pu)
    assert data["base"] == expected.base and data["order"] == expected.order
    assert data["inputs"]["speed_rpm"] == 800 and data["inputs"]["current_a"] == 25
    for key, value in kwargs.items():
        if key in data["inputs"] and isinstance(value, float):
            assert data["inputs"][key] == pytest.approx(value)


def test_predict_human_output(capsys):
    code, out, _ = run_cli(capsys, "predict", "gain_mismatch", "--ia-gain-error-pct", "1",
                           "--ib-gain-error-pct", "-1")
    assert code == 0
    assert out.startswith("gain_mismatch: 2.309 % pk-pk")


@pytest.mark.parametrize("argv,names", [
    (["predict", "encoder", "--resolution-deg", "-1"], "--resolution-deg"),
    (["predict", "encoder", "--encoder-decimation", "0"], "--encoder-decimation"),
    (["predict", "word_length", "--word-length-bits", "0"], "--word-length-bits"),
    (["predict", "dc_offset", "--offset-a-pct", "200"], "--offset-a-pct"),
    (["predict", "dc_offset", "--ia-offset-a", "25"], "--ia-offset-a"),
    (["predict", "gain_mismatch", "--ia-gain-error-pct", "50"], "--ia-gain-error-pct"),
    (["predict", "dead_time", "--dead-time-us", "-2"], "--dead-time-us"),
    (["predict", "dead_time"], "--dead-time-us"),
    (["predict", "pwm_resolution"], "--pwm-bits"),
    (["predict", "encoder", "--dead-time-us", "2"], "--dead-time-us"),
    (["predict", "dc_offset", "--current-a", "0"], "--current-a"),
    (["predict", "dc_offset", "--speed-rpm", "5000"], "--speed-rpm"),
    (["predict", "dead_time", "--dead-time-us", "2", "--model", "average_voltage",
      "--speed-rpm", "0"], "--speed-rpm"),
    (["budget", "--limit-pct", "0"], "--limit-pct"),
    (["budget", "--limit-pct", "2", "--offset-a-pct", "300"], "--offset-a-pct"),
])
def test_bad_input_is_one_line_naming_the_option(capsys, argv, names):
    code, out, err = run_cli(capsys, *argv)
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and names in err and "allowed" in err


def test_unknown_source_is_refused_by_the_console_script():
    done = subprocess.run([sys.executable, "-m", "hil", "predict", "cogging"], capture_output=True,
                          text=True, timeout=60)
    assert done.returncode == 2 and done.stdout == ""
    assert done.stderr.count("\n") == 1 and "cogging" in done.stderr and "encoder" in done.stderr
    assert "Traceback" not in done.stderr


def test_budget_json(capsys):
    code, out, err = run_cli(capsys, "budget", "--limit-pct", "2", "--json",
                             "--encoder-decimation", "100", "--offset-a-pct", "0.5")
    assert code == 1 and err == ""      # not attainable (PWM switching, below): exit 1
    data = json.loads(out)
    assert data["limit_pu"] == pytest.approx(0.02) and data["allocation"] == "equal_sum"
    # at 1000 rpm, 20 A the switching ripple alone exceeds its share even at 50 kHz: said so,
    # and the check (every source at its limit) shows the sum over the limit
    assert data["limits"]["pwm_switching"]["met"] is False
    assert "pwm_switching" in data["check"]["contributions_pu"]
    assert data["check"]["worst_case_sum_pu"] > 0.02
    assert set(data["limits"]) == {"encoder", "word_length", "dc_offset", "gain_mismatch",
                                   "pwm_resolution", "pwm_switching", "dead_time"}
    assert set(data["models"]) == set(data["limits"])
    combination = data["combination"]
    assert set(combination["contributions_pu"]) == {"encoder", "dc_offset"}
    assert combination["meets_worst_case"] is (combination["worst_case_sum_pu"] <= 0.02)


def test_budget_human(capsys):
    code, out, _ = run_cli(capsys, "budget", "--limit-pct", "2", "--allocation", "alone")
    bits = invert(OperatingPoint(1000, 20.0), 0.02, allocation="alone").limits["word_length"]
    assert code == 1 and f"shortest {bits['word_length_bits']} bits" in out
    assert "worst-case sum" in out


def test_predict_json_waveform_on_request(capsys):
    code, out, _ = run_cli(capsys, "predict", "dc_offset", "--offset-a-pct", "1", "--json",
                           "--waveform")
    data = json.loads(out)
    assert code == 0 and len(data["angle_rad"]) == len(data["waveform_pu"]) == 3600
    assert max(data["waveform_pu"]) - min(data["waveform_pu"]) == pytest.approx(data["pk_pk_pu"])


def test_model_does_not_import_the_simulation_or_drivers():
    code = ("import sys, hil.model, hil.model.budget; "
            "bad = [m for m in sys.modules if m.startswith(('hil.sim', 'ripple_hil_drivers'))]; "
            "print(bad); sys.exit(1 if bad else 0)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stdout + done.stderr


@pytest.mark.parametrize("command", ["predict", "budget"])
def test_help_lists_the_options(capsys, command):
    with pytest.raises(SystemExit) as done:
        main([command, "--help"])
    out = " ".join(capsys.readouterr().out.split())
    assert done.value.code == 0 and "--offset-a-pct PCT" in out
    assert "% of the current amplitude" in out
