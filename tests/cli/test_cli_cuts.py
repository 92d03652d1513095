"""The CLI cuts of issue 12 item 6 in predict, budget, analyze, ``hil --help`` and ``--json``
errors: one test each (issue 13 item 7's ``--target-pct`` too)."""

import json
import math
import re

import pytest

from hil.cli import main
from hil.commands.predict import SOURCE_OPTIONS
from hil.model import OperatingPoint, SOURCES, predict, source_parameters
from hil.model.budget import DESIGN_SOURCES

PYTHON_NAME = re.compile(r"(?<![\w-])[a-z]+(?:_[a-z0-9]+)+(?![\w-])")


def run_cli(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def allowed_list(err):
    return err.split("(allowed: ", 1)[1].rsplit(")", 1)[0]


@pytest.mark.parametrize("source", list(SOURCES))
def test_every_predict_keyword_has_an_option(source):
    """So no error of ``hil predict`` can name a keyword the user cannot type."""
    flags = {option.param for option in SOURCE_OPTIONS if source in option.sources}
    assert set(source_parameters(source)) - flags - {"hall_mode"} == set()


@pytest.mark.parametrize("source", ["word_length", "dead_time", "pwm_resolution"])
def test_missing_parameter_errors_list_options_only(capsys, source):
    code, out, err = run_cli(capsys, "predict", source)
    assert code == 2 and out == "" and err.count("\n") == 1
    if "(allowed: " in err:
        listed = [name.strip() for name in allowed_list(err).split(",")]
        assert all(name.startswith("--") for name in listed), err
    assert "--" in err and not PYTHON_NAME.findall(err.split(":", 2)[2].replace(source, "")), err


def test_word_length_missing_bits_lists_options_only(capsys):
    code, out, err = run_cli(capsys, "predict", "word_length")
    assert code == 2 and out == ""
    listed = [name.strip() for name in allowed_list(err).split(",")]
    assert "--word-length-bits" in listed and all(name.startswith("--") for name in listed), err
    assert "full_scale_current_a" not in err and "--full-scale-current-a" in err


def test_dead_time_lists_the_delay_flag_that_exists(capsys):
    code, _, err = run_cli(capsys, "predict", "dead_time")
    assert code == 2 and "--current-loop-delay-us" in err and "current_loop_delay_s" not in err
    # ... and that flag is accepted, in µs
    code, out, _ = run_cli(capsys, "predict", "dead_time", "--dead-time-us", "2", "--model",
                           "average_voltage", "--current-loop-bandwidth-hz", "1600",
                           "--current-loop-delay-us", "75", "--json")
    assert code == 0 and json.loads(out)["inputs"]["current_loop_delay_s"] == pytest.approx(75e-6)


@pytest.mark.parametrize("pair", [["--resolution-deg", "10", "--encoder-decimation", "5"],
                                  ["--resolution-deg", "10", "--encoder-counts-per-rev", "720"],
                                  ["--hall-mode", "--encoder-decimation", "5"],
                                  ["--hall-mode", "--resolution-deg", "10"]])
def test_encoder_resolution_stated_two_ways_is_refused(capsys, pair):
    code, out, err = run_cli(capsys, "predict", "encoder", *pair)
    assert code == 2 and out == "" and err.count("\n") == 1 and "allowed" in err
    assert pair[0] in err


def test_encoder_target_pct_finds_the_lagging_current_angle(capsys):
    code, out, _ = run_cli(capsys, "predict", "encoder", "--encoder-decimation", "100",
                           "--target-pct", "10", "--json")
    data = json.loads(out)
    assert code == 0 and data["target"]["branch"] == "lagging"
    phi = math.radians(data["target"]["current_angle_deg"])
    assert 0 < phi < math.pi / 2
    check = predict("encoder", OperatingPoint(1000, 20.0, phi), encoder_decimation=100)
    assert check.pk_pk_pu == pytest.approx(0.10, rel=1e-6) == data["pk_pk_pu"]
    code, out, err = run_cli(capsys, "predict", "encoder", "--encoder-decimation", "100",
                             "--target-pct", "1")
    assert code == 2 and "unreachable on the lagging branch" in err and "1.527 %" in err
    code, _, err = run_cli(capsys, "predict", "encoder", "--target-pct", "5",
                           "--current-angle-deg", "10")
    assert code == 2 and "--current-angle-deg" in err
    code, _, err = run_cli(capsys, "predict", "dc_offset", "--target-pct", "5")
    assert code == 2 and "allowed for: encoder" in err


def test_budget_includes_every_source_and_names_each_model(capsys):
    code, out, _ = run_cli(capsys, "budget", "--limit-pct", "2")
    assert code == 1            # PWM switching alone exceeds its share: the limit is not attainable
    for source in DESIGN_SOURCES:
        assert re.search(rf"^  {source}\s", out, re.M), source
    assert out.count("model: ") == len(DESIGN_SOURCES) == 7
    assert "pwm_switching" in out
    dead_model = out.split("dead_time", 1)[1].split("model: ", 1)[1].splitlines()[0]
    assert "average-voltage" in dead_model and "eq 38 is ~4x too high" in dead_model
    assert "assumed: the simulated drive's" in out
    code, out, _ = run_cli(capsys, "budget", "--limit-pct", "2", "--json")
    data = json.loads(out)
    assert set(data["models"]) == set(data["limits"]) == set(DESIGN_SOURCES)
    assert data["limits"]["dead_time"]["model"] == "average_voltage"


def test_analyze_text_file_does_not_suggest_allow_pickle(capsys):
    code, out, err = run_cli(capsys, "analyze", "README.md")
    assert code == 2 and out == "" and err.count("\n") == 1
    assert "pickle" not in err and "--time-col" in err


def test_analyze_directory_is_not_reported_missing(capsys, tmp_path):
    code, _, err = run_cli(capsys, "analyze", str(tmp_path))
    assert code == 2 and "is a directory" in err and "does not exist" not in err
    code, _, err = run_cli(capsys, "analyze", str(tmp_path / "absent.npz"))
    assert code == 2 and "does not exist" in err


@pytest.mark.parametrize("argv,flag", [(["--top", "-3"], "--top"), (["--top", "0"], "--top"),
                                       (["--max-order", "0"], "--max-order"),
                                       (["--rated-torque-nm", "-1"], "--rated-torque-nm")])
def test_analyze_refuses_nonsense_counts(capsys, tmp_path, argv, flag):
    code, out, err = run_cli(capsys, "analyze", str(tmp_path / "c.npz"), *argv)
    assert code == 2 and out == "" and flag in err and "Traceback" not in err


@pytest.mark.parametrize("command", [[], ["predict"], ["budget"], ["analyze"]])
def test_help_has_no_raw_docstring_markup(capsys, command):
    with pytest.raises(SystemExit) as done:
        main([*command, "--help"])
    out = capsys.readouterr().out
    assert done.value.code == 0 and "``" not in out and ":func:" not in out
    if not command:
        assert "torque ripple" in out and "COMMAND --help" in out


@pytest.mark.parametrize("argv,kind", [
    (["predict", "encoder", "--resolution-deg", "-1", "--json"], "input"),
    (["predict", "cogging", "--json"], "usage"),
    (["budget", "--limit-pct", "0", "--json"], "input"),
    (["analyze", "README.md", "--json"], "input"),
    (["analyze", "x.npz", "--top", "many", "--json"], "usage"),
])
def test_json_errors_are_one_json_object(capsys, argv, kind):
    code, out, err = run_cli(capsys, *argv)
    assert code == 2 and err.count("\n") == 1
    error = json.loads(out)["error"]
    assert error["kind"] == kind and error["exit_status"] == 2
    assert error["command"].startswith("hil") and error["message"] in err


def test_no_command_help_is_cut_mid_sentence():
    """Each command's --help description is a whole paragraph: it ends a sentence (issue 32,
    "Why" 6: compare, trend and history stopped at the end of a docstring line)."""
    from hil.cli import COMMANDS, build_parser

    for command in COMMANDS:
        parser = build_parser([command])
        sub = next(action for action in parser._actions
                   if getattr(action, "choices", None) and command in action.choices)
        text = sub.choices[command].description or ""
        assert text.rstrip().endswith((".", ")", ":")), (command, text)
