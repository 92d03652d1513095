"""Issue 30, "a verdict must be right off the default path": the 2-pole 24 V study motor at
±250 rpm (L/R 0.25 ms, f_e 4.17 Hz), where the correct simulated drive failed the dead-time and
PWM-resolution plans (hil/model/README.md, "Capture rate against the transducer's bandwidth"
and "Dead time beyond the calibrated plant corner").

Fast checks here: the capture-rate floor and the dead-time region's plant-corner limit. The
plans run end to end on that motor in ``tests/model/test_low_time_constant_plans.py``.
"""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path
from types import SimpleNamespace

import pytest
import tomllib
import tomli_w

from hil.config import example_bench_path, load_bench
from hil.measurement import PointPlan
from hil.validity import DEAD_TIME_MAX_PLANT_CORNER_ORDER, plant_corner_order, problems
from ripple_hil_testplans import conditions as c
from ripple_hil_testplans.test_dead_time import plan as dead_time_plan
from ripple_hil_testplans.test_pwm_resolution import plan as pwm_resolution_plan

STUDY = Path(__file__).resolve().parents[2] / "studies" / "validity.py"


def study_motor(name: str = "p2_24v") -> dict:
    """A study motor's ``[motor]`` table (studies/validity.py MOTORS)."""
    spec = importlib.util.spec_from_file_location("validity_study", STUDY)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return dict(module.MOTORS[name])


P2_24V = study_motor()


def bench(tmp_path, speed_rpm: float, current_a: float, motor: dict | None = None):
    table = tomllib.loads(example_bench_path("sim-bench").read_text())
    table["operating_point"] = {"speed_rpm": speed_rpm, "current_a": current_a,
                                "current_angle_deg": 0.0}
    if motor is not None:
        table["motor"] = dict(motor)
    path = tmp_path / f"bench_{speed_rpm:g}_{current_a:g}.toml"
    path.write_text(tomli_w.dumps(table))
    return load_bench(path)


def test_the_capture_rate_is_raised_to_four_times_the_transducer_bandwidth(tmp_path):
    """At 4.17 Hz electrical the order rule gives 2 kHz (48 orders × 10 points), where the 1 kHz
    transducer still passes the drive's broadband content to the Nyquist frequency: both plans
    now capture at 4 kHz; where the order rule already gives more, nothing changes."""
    low = bench(tmp_path, 250.0, 5.0, P2_24V)
    for make in (dead_time_plan, pwm_resolution_plan):
        point = make(low, {"dead_time_s": 2e-6} if make is dead_time_plan
                     else {"pwm_period_counts": 32})
        assert point.capture_rate_hz(1) == 4000.0
        # the analysed band and capture are otherwise the plan's own
        assert point.max_order == 48
    fast = bench(tmp_path, 1000.0, 20.0)                          # Table I: 33 Hz electrical
    default = PointPlan(source="dead_time", injection={"dead_time_s": 2e-6},
                        speed_rpm=1000.0, current_a=20.0)
    assert dead_time_plan(fast, {"dead_time_s": 2e-6}).capture_rate_hz(2) == \
        default.capture_rate_hz(2) == 16_000.0


def test_no_stated_transducer_bandwidth_leaves_the_rate_alone():
    point = PointPlan(source="dead_time", injection={}, speed_rpm=250.0, current_a=5.0)
    config = SimpleNamespace(torque=SimpleNamespace(bandwidth_hz=None),
                             motor=SimpleNamespace(pole_pairs=1))
    assert c.transducer_limited_rate(point, config) is point


def test_the_calibration_set_sets_the_plant_corner_limit():
    """The limit is the calibration set's largest judged corner order (Table I at 125 rpm,
    54.6), rounded up: not a figure of the study motor where the validity study judges."""
    from hil.motor import TABLE_I

    table_i = SimpleNamespace(motor=TABLE_I)
    assert plant_corner_order(table_i, 125.0) == pytest.approx(54.57, abs=0.01)
    assert plant_corner_order(table_i, 125.0) <= DEAD_TIME_MAX_PLANT_CORNER_ORDER < 60.0
    assert plant_corner_order(table_i, 0.0) == math.inf


def test_dead_time_on_the_2_pole_motor_at_250_rpm_is_refused_with_the_reason(tmp_path):
    """k_c = R/(L·ω_e) = 153 at ±250 rpm and 76 at 500 rpm: not determinable, the reason names
    the corner; at 1000 rpm (k_c 38) and on Table I at 180 rpm (k_c 38) the corner does not
    refuse; the PWM-resolution plan has no such limit (its readings were the capture's)."""
    def corner(config, dead_time_s=2e-6):
        return [p for p in problems(dead_time_plan(config, {"dead_time_s": dead_time_s}), config)
                if p.startswith("plant corner")]

    for speed, order in ((250.0, "153"), (-250.0, "153"), (500.0, "76.4")):
        config = bench(tmp_path, speed, 5.0, P2_24V)
        found = corner(config)
        assert found and found[0].startswith(
            "plant corner beyond the dead_time calibration: R/(L·ω_e) = order "
            f"{order} at {speed:g} rpm (L/R 0.25 ms) vs <= 55"), found
        assert not problems(pwm_resolution_plan(config, {"pwm_period_counts": 32}), config)
    assert not corner(bench(tmp_path, 1000.0, 5.0, P2_24V))
    assert not corner(bench(tmp_path, 180.0, 8.0), 3e-6)
