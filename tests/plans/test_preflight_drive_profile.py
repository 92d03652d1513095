"""Pre-flight with a drive profile (hil.preflight.missing_knob_refusal): a point that needs a knob
the drive under test cannot inject is not determinable here, with the knob named; a faulty
profile stops the run with one line; the shipped drive refuses nothing."""

from __future__ import annotations

from pathlib import Path

import pytest

from hil.config import default_sim_bench
from hil.measurement import PointPlan
from hil.preflight import check_plans, check_point, hard_problems, missing_knob_refusal
from hil.validity import injected_or_default
from ripple_hil_testplans import conditions as c

OTHER = Path(__file__).resolve().parents[1] / "data" / "other_drive"
SHIPPED = default_sim_bench()


def bench(profile: str, eds: str = "eps_drive.eds"):
    return SHIPPED.with_overrides({"drive": {"eds": str(OTHER / eds),
                                             "profile": str(OTHER / profile)}})


EPS, NOTHING = bench("eps_drive_profile.toml"), bench("no_injection_profile.toml")


def point(injection=None, **overrides):
    settings = {"source": "dc_offset", "injection": injection or {}, "speed_rpm": 500.0,
                "current_a": 20.0, "rule": c.CLOSED_FORM_RULE}
    return PointPlan(**settings | overrides)


@pytest.mark.parametrize("injection", [
    *c.WORD_LENGTH_SWEEP, *c.ENCODER_SWEEP, *c.PWM_RESOLUTION_SWEEP])
def test_a_point_needing_a_knob_the_eps_drive_lacks_is_not_determinable(injection):
    knob = next(iter(injection))
    plan = point(injection)
    assert missing_knob_refusal(plan, EPS) == f"the drive under test has no {knob}"
    assert missing_knob_refusal(plan, SHIPPED) is None
    assert not any("no " + knob in p for p in hard_problems(plan, EPS))   # not a hard error
    assert f"the drive under test has no {knob}" in check_point(plan, EPS)


@pytest.mark.parametrize("injection", [
    *c.DEAD_TIME_SWEEP, *c.GAIN_SWEEP, *c.PWM_SWITCHING_SWEEP, {"ia_offset_a": 0.2}])
def test_a_point_the_eps_drive_can_inject_is_not_refused(injection):
    assert missing_knob_refusal(point(injection), EPS) is None


def test_a_drive_with_no_injection_refuses_every_injection_and_a_current_angle():
    assert missing_knob_refusal(point(), NOTHING) is None           # baseline, ripple map
    assert missing_knob_refusal(point({"ia_offset_a": 0.2}), NOTHING) == \
        "the drive under test has no ia_offset_a"
    assert missing_knob_refusal(point(current_angle_rad=0.3), NOTHING) == \
        "the drive under test has no current_angle_rad"
    assert missing_knob_refusal(point(current_angle_rad=0.3), EPS) is None


def test_a_lacking_knob_at_the_value_the_drive_runs_at_is_no_refusal():
    """[fixed] states it (encoder decimation 1); else the shipped default (PWM period 2000)."""
    assert missing_knob_refusal(point({"encoder_decimation": 1}), EPS) is None
    assert missing_knob_refusal(point({"pwm_period_counts": 2000}), EPS) is None
    assert injected_or_default(point(), EPS, "dead_time_s") == 0.0
    assert injected_or_default(point(), EPS, "pwm_frequency_hz") == 20000.0


def test_a_faulty_profile_stops_the_run_with_one_line(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text((OTHER / "eps_drive_profile.toml").read_text().replace("0x3010", "0x3999"))
    config = SHIPPED.with_overrides({"drive": {"eds": str(OTHER / "eps_drive.eds"),
                                               "profile": str(bad)}})
    lines = check_plans({"t": point({"ia_offset_a": 0.2})}, config)
    assert lines == ["t: drive profile bad.toml: knobs.dead_time_s: object 0x3999:00 is not in "
                     "the EDS eps_drive.eds"]


def test_an_unknown_knob_stays_a_hard_problem_on_any_drive():
    for config in (SHIPPED, EPS):
        assert any("not a knob of the drive's EDS" in p
                   for p in hard_problems(point({"ia_ofset_a": 0.2}), config))


def test_the_bench_file_key_selects_the_profile(tmp_path):
    from hil.config import load_bench
    from ripple_hil_drivers.drive_profile import profile_for

    path = tmp_path / "bench.toml"
    text = (Path(__file__).resolve().parents[2] / "hil" / "examples" / "sim-bench.toml").read_text()
    path.write_text(text.replace("[drive]\n", f"[drive]\neds = \"{OTHER / 'eps_drive.eds'}\"\n"
                                 f"profile = \"{OTHER / 'eps_drive_profile.toml'}\"\n", 1))
    assert profile_for(load_bench(path).drive).name == "EPS-400 inverter (example)"
    assert profile_for(SHIPPED.drive).name == "ripple-hil drive (ripple_drive.eds)"
