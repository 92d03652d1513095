"""Tolerance files: what loads, and one-line errors naming the key for what does not."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from hil.errors import InputError
from hil.tolerance.distributions import Choice, Fixed, Normal, Uniform
from hil.tolerance.spec import load_tolerances, parse_tolerances

EXAMPLE = Path(__file__).resolve().parents[2] / "hil" / "examples" / "tolerances.toml"
POINT = {"operating_point": [{"speed_rpm": 500, "current_a": 20}]}


def test_shipped_example_loads():
    spec = load_tolerances(EXAMPLE)
    assert spec.requirement.limit_pct == 3.0 and len(spec.operating_points) == 2
    assert isinstance(spec.parameters["ia_offset_a"], Normal)
    assert isinstance(spec.parameters["ia_gain_error_pu"], Uniform)
    assert isinstance(spec.parameters["encoder_counts_per_rev"], Choice)
    assert isinstance(spec.parameters["word_length_bits"], Fixed)
    assert isinstance(spec.parameters["pwm_period_counts"], Fixed)  # not given: nominal
    assert "word_length_bits" not in spec.varied and "encoder_counts_per_rev" in spec.varied


@pytest.mark.parametrize("doc, key", [
    ({**POINT, "parameters": {"ia_ofset_a": {"distribution": "fixed", "value": 0}}},
     "parameters.ia_ofset_a: unknown parameter"),
    ({**POINT, "parameters": {"word_length_bits": {"distribution": "normal", "sigma": 1}}},
     "parameters.word_length_bits: word_length_bits is an integer"),
    ({**POINT, "parameters": {"ia_offset_a": {"distribution": "normal"}}},
     "parameters.ia_offset_a.sigma is missing"),
    ({**POINT, "parameters": {"ia_offset_a": {"distribution": "normal", "sigma": -0.1}}},
     "parameters.ia_offset_a.sigma=-0.1 is out of range"),
    ({**POINT, "parameters": {"dead_time_s": {"distribution": "uniform", "half_width": 1e-6}}},
     "parameters.dead_time_s: mean ± half_width"),
    ({**POINT, "parameters": {"dead_time_s": {"distribution": "gauss", "sigma": 1e-7}}},
     "parameters.dead_time_s.distribution='gauss'"),
    ({**POINT, "parameters": {"dead_time_s": {"distribution": "normal", "sigma": 1e-7,
                                              "stdev": 1}}},
     "parameters.dead_time_s.stdev: not a field of a normal distribution"),
    ({**POINT, "parameters": {"encoder_counts_per_rev": {"distribution": "choice",
                                                         "values": [2048, 7200],
                                                         "weights": [1]}}},
     "parameters.encoder_counts_per_rev.weights must be an array as long as values"),
    ({**POINT, "parameters": {"encoder_counts_per_rev": {"distribution": "choice",
                                                         "values": [2048, 7200],
                                                         "weights": [3, 7]}}},
     "parameters.encoder_counts_per_rev.weights: choice weights sum to 10, not 1"),
    ({**POINT, "parameters": {"encoder_counts_per_rev": {"distribution": "choice",
                                                         "values": [2048, 4096, 7200],
                                                         "weights": [0.3, 0.3, 0.3]}}},
     "parameters.encoder_counts_per_rev.weights: choice weights sum to 0.9, not 1"),
    ({**POINT, "parameters": {"hall_mode": {"distribution": "choice", "values": [0, 1],
                                            "weights": [0.5, 0.5 + 2e-9]}}},
     "parameters.hall_mode.weights: choice weights sum to 1.000000002, not 1"),
    ({**POINT, "parameters": {"word_length_bits": {"distribution": "fixed", "value": 4}}},
     "parameters.word_length_bits.value=4: word_length_bits is 0"),
    ({**POINT, "parameters": {"ia_offset_a": {"distribution": "fixed", "value": "0.1"}}},
     "parameters.ia_offset_a.value='0.1' is not a number"),
    ({}, "missing \\[\\[operating_point\\]\\]"),
    ({"operating_point": [{"speed_rpm": 0, "current_a": 20}]}, "operating_point\\[0\\].speed_rpm=0"),
    ({"operating_point": [{"speed_rpm": 500}]}, "operating_point\\[0\\].current_a is missing"),
    ({"operating_point": [{"speed_rpm": 2500, "current_a": 10}]},
     "operating_point\\[0\\]: speed_rpm=2500 .* beyond"),
    ({**POINT, "requirement": {"id": "R", "name": "n", "quantity": "rms_pct",
                               "limit": {"max": 1}}},
     "\\[requirement\\]: quantity = 'rms_pct': hil yield judges pk_pk_pct only"),
    ({**POINT, "requirement": {"id": "R", "name": "n", "quantity": "pk_pk_pct",
                               "limit": {"min": 1}}},
     "\\[requirement\\]: limit must be \\{max = PERCENT\\} only"),
    ({**POINT, "requirement": {"id": "R", "quantity": "pk_pk_pct", "limit": {"max": 1}}},
     "requirement 'R': missing key 'name'"),
    ({**POINT, "drives": 0}, "drives=0 must be an integer"),
    ({**POINT, "limit_pct": 3}, "unknown key 'limit_pct'"),
])
def test_bad_tolerance_documents_name_the_key(doc, key):
    with pytest.raises(InputError, match=key) as error:
        parse_tolerances(doc, source="t.toml")
    assert "\n" not in str(error.value) and str(error.value).startswith("t.toml:")


def test_choice_weights_are_probabilities_within_1e9_of_one():
    """Weights summing to 1 within 1e-9 load (three thirds, the default equal weights); the
    drawn frequencies follow them — nothing is renormalised behind the file's back."""
    doc = {**POINT, "parameters": {"encoder_counts_per_rev": {
        "distribution": "choice", "values": [2048, 4096, 7200],
        "weights": [1 / 3, 1 / 3, 1 / 3 + 5e-10]}}}
    assert isinstance(parse_tolerances(doc).parameters["encoder_counts_per_rev"], Choice)
    doc["parameters"]["encoder_counts_per_rev"]["weights"] = [0.1, 0.2, 0.7]
    choice = parse_tolerances(doc).parameters["encoder_counts_per_rev"]
    drawn = choice.sample(np.random.default_rng(1), 200_000)
    shares = [np.mean(drawn == v) for v in (2048, 4096, 7200)]
    assert shares == pytest.approx([0.1, 0.2, 0.7], abs=0.005)
    del doc["parameters"]["encoder_counts_per_rev"]["weights"]
    assert parse_tolerances(doc).parameters["encoder_counts_per_rev"].weights == \
        pytest.approx((1 / 3,) * 3)
    with pytest.raises(InputError, match="choice weights sum to 2, not 1"):
        Choice((1.0, 2.0), (1.0, 1.0))  # built in code: refused as well


def test_requirement_applies_at_its_points_only(tmp_path):
    doc = {"operating_point": [{"speed_rpm": 500, "current_a": 20},
                               {"speed_rpm": 1500, "current_a": 10}],
           "requirement": {"id": "R", "name": "n", "quantity": "pk_pk_pct",
                           "limit": {"max": 3.0}, "speed_rpm": [1000, 2000]}}
    spec = parse_tolerances(doc).with_requirement()
    assert spec.judged == [1]
    assert list(spec.worst_pu([[0.5, 0.01], [0.0, 0.04]])) == [0.01, 0.04]
    doc["requirement"]["current_a"] = 50
    with pytest.raises(InputError, match="applies to none of the operating points"):
        parse_tolerances(doc).with_requirement()
    lines = tmp_path / "req.toml"
    lines.write_text('[[requirement]]\nid = "A"\nname = "a"\nquantity = "pk_pk_pct"\n'
                     'limit = { max = 2.0 }\n[[requirement]]\nid = "B"\nname = "b"\n'
                     'quantity = "rms_pct"\nlimit = { max = 1.0 }\n')
    done = subprocess.run([sys.executable, "-m", "hil", "yield", str(EXAMPLE), "--requirements",
                           str(lines), "--requirement-id", "B", "--scheduler", "inline"],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and "hil yield judges pk_pk_pct only" in done.stderr
    done = subprocess.run([sys.executable, "-m", "hil", "yield", str(EXAMPLE), "--requirements",
                           str(lines), "--drives", "2000", "--sobol-n", "0", "--scheduler",
                           "inline", "--out", str(tmp_path / "out"), "--json"],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    judged = json.loads(done.stdout)["requirement"]
    assert judged["id"] == "A" and judged["limit"] == {"max": 2.0}


def test_missing_limit_needs_the_command_line():
    spec = parse_tolerances(POINT)
    with pytest.raises(InputError, match="no \\[requirement\\] table and no --limit-pct"):
        spec.with_requirement()
    assert spec.with_requirement(2.5).requirement.limit_pct == 2.5


def test_cli_bad_file_is_one_line_exit_2(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text('[[operating_point]]\nspeed_rpm = 500\ncurrent_a = 20\n'
                   '[parameters.dead_time_s]\ndistribution = "normal"\nmean = 1e-6\n')
    done = subprocess.run([sys.executable, "-m", "hil", "yield", str(bad), "--limit-pct", "3",
                           "--scheduler", "inline"], capture_output=True, text=True, timeout=120)
    assert done.returncode == 2
    assert done.stderr.strip().count("\n") == 0
    assert "parameters.dead_time_s.sigma is missing" in done.stderr
    broken = tmp_path / "broken.toml"
    broken.write_text("drives = [")
    done = subprocess.run([sys.executable, "-m", "hil", "yield", str(broken)],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and "not valid TOML" in done.stderr
