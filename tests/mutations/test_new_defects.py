"""The issue-21 test-only defects (``hil.sim.defects``) do what they say: each defective twin is
compared with a healthy twin told what the defect amounts to, so every check can fail."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from hil.errors import InputError
from hil.sim import DriveConfig, DriveTwin, FirmwareModel, Injection, TransducerModel
from hil.sim.defects import DriveDefects, parse_defect_option

OPERATING = DriveConfig(current_command_a=20.0, speed_rpm=500.0)
DURATION_S, RATE_HZ, SETTLE_S = 0.004, 20_000.0, 0.003


def run(injection: dict, defects: DriveDefects | None = None, config: DriveConfig = OPERATING):
    twin = DriveTwin(config, seed=2, defects=defects)
    if injection:
        twin.set_injection(**injection)
    return twin.advance(DURATION_S, RATE_HZ, settle_s=SETTLE_S), twin.injection


def same(a: dict, b: dict, names=("ia_a", "ib_a", "torque_em_nm", "torque_nm")) -> bool:
    return all(np.array_equal(a[name], b[name]) for name in names)


def test_swapped_sensor_injections_land_on_the_other_sensor():
    commanded = {"ia_offset_a": 0.3, "ia_gain_error_pu": 0.02, "ib_gain_error_pu": -0.01}
    defective, read_back = run(commanded, DriveDefects(sensor_injection_swapped=True))
    swapped, _ = run({"ib_offset_a": 0.3, "ib_gain_error_pu": 0.02, "ia_gain_error_pu": -0.01})
    straight, _ = run(commanded)
    assert read_back == Injection(**commanded)               # the drive reads back what was told
    assert same(defective, swapped) and not same(defective, straight)


def test_gain_applied_as_the_reciprocal():
    defects = DriveDefects(gain_applied_inverse=True)
    applied = defects.applied(Injection(ia_gain_error_pu=0.02, ib_gain_error_pu=-0.02))
    assert applied.ia_gain_error_pu == pytest.approx(1 / 1.02 - 1)
    assert applied.ib_gain_error_pu == pytest.approx(1 / 0.98 - 1)
    defective, _ = run({"ia_gain_error_pu": 0.02}, defects)
    told, _ = run({"ia_gain_error_pu": 1 / 1.02 - 1})
    assert same(defective, told)


def test_encoder_index_offset_moves_the_current_angle():
    defects = DriveDefects(encoder_index_offset_rad=0.35)
    defective, read_back = run({"current_angle_rad": 0.1}, defects)
    told, _ = run({"current_angle_rad": 0.1 - 0.35})
    assert read_back.current_angle_rad == 0.1 and same(defective, told)


def test_dead_time_compensation_leaves_part_of_the_dead_time():
    defective, _ = run({"dead_time_s": 2e-6}, DriveDefects(dead_time_compensation_pu=0.7))
    told, _ = run({"dead_time_s": 2e-6 * 0.3})
    assert same(defective, told)


def test_transducer_extra_lag_lowers_the_transducer_bandwidth_only():
    defects = DriveDefects(transducer_extra_lag_s=1e-3)
    tau_s = 1 / (2 * math.pi * 1000.0) + 1e-3
    slow = replace(OPERATING, transducer=TransducerModel(bandwidth_hz=1 / (2 * math.pi * tau_s)))
    assert defects.applied_config(OPERATING) == slow
    defective, _ = run({}, defects)
    told, _ = run({}, config=slow)
    healthy, _ = run({})
    assert same(defective, told)
    assert same(defective, healthy, ("ia_a", "ib_a", "torque_em_nm"))   # the drive is the same
    assert not np.array_equal(defective["torque_nm"], healthy["torque_nm"])


def test_slower_current_loop():
    defects = DriveDefects(current_loop_bandwidth_scale=0.5)
    slow = replace(OPERATING, firmware=FirmwareModel(bandwidth_per_pwm=0.04))
    assert defects.applied_config(OPERATING) == slow
    defective, _ = run({"dead_time_s": 1e-6}, defects)
    told, _ = run({"dead_time_s": 1e-6}, config=slow)
    healthy, _ = run({"dead_time_s": 1e-6})
    assert same(defective, told) and not same(defective, healthy)


def test_the_new_defects_parse_from_the_command_line_and_are_checked():
    pairs = dict(parse_defect_option(t) for t in (
        "sensor_injection_swapped=true", "gain_applied_inverse=true",
        "encoder_index_offset_rad=0.35", "dead_time_compensation_pu=0.7",
        "transducer_extra_lag_s=1e-3", "current_loop_bandwidth_scale=0.5"))
    defects = DriveDefects.from_dict(pairs)
    assert defects.to_dict() == pairs
    for bad in ({"sensor_injection_swapped": 1}, {"gain_applied_inverse": "yes"},
                {"encoder_index_offset_rad": 4.0}, {"dead_time_compensation_pu": 1.5},
                {"transducer_extra_lag_s": -1e-3}, {"current_loop_bandwidth_scale": 0.0}):
        with pytest.raises(InputError, match=next(iter(bad))):
            DriveDefects.from_dict(bad)
