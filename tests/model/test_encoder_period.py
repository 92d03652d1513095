"""Encoder count orders that are not a whole number per electrical revolution (issue 30 item 4):
the staircase is analysed over its common period, or the point is refused with the reason.

The hole: 7200 counts on a 10-pole motor at decimation 25 make 57.6 steps per electrical
revolution; the plan judged "order 58" of a one-revolution analysis (a smeared line, type-A U
larger than the value) and failed a correct drive at every point.
"""

from __future__ import annotations

import dataclasses
import math
import tomllib

import numpy as np
import pytest
import tomli_w

from hil.analysis.metrics import analyze_capture
from hil.capture import Capture
from hil.config import example_bench_path, load_bench
from hil.errors import InputError
from hil.measurement import PointPlan, analysed_order
from hil.model.encoder import count_order_amplitude_pu, count_period
from hil.validity import problems
from ripple_hil_testplans import test_encoder

TEN_POLE = {"model": "10-pole 48 V PMSM (test)", "serial_number": "T-P10", "pole_count": 10,
            "dc_bus_v": 48.0, "phase_resistance_ohm": 0.12, "phase_inductance_h": 0.4e-3,
            "max_reactance_ohm": 0.5, "ke_v_s_per_rad": 0.05, "ke_definition": "rms_phase"}


def bench_with(tmp_path, motor: dict):
    table = tomllib.loads(example_bench_path("sim-bench").read_text())
    table["motor"] |= motor
    path = tmp_path / "bench.toml"
    path.write_text(tomli_w.dumps(table))
    return load_bench(path)


@pytest.mark.parametrize("pole_pairs, decimation, expected", [
    (2, 25, (1, 144)),      # Table I: divides
    (5, 25, (5, 288)),      # 10 poles: 57.6 per electrical revolution
    (5, 100, (5, 72)),      # 14.4
    (7, 25, (7, 288)),      # 14 poles: 288/7
    (6, 25, (1, 48)),       # 12 poles: divides
    (2, 7, (7, 3600)),      # a decimation that does not divide the 7200 counts
])
def test_count_period(pole_pairs, decimation, expected):
    assert count_period(pole_pairs=pole_pairs, encoder_decimation=decimation) == expected


def test_count_period_of_hall_and_of_an_angle():
    assert count_period(pole_pairs=5, hall_mode=True) == (1, 6)
    assert count_period(pole_pairs=5, resolution_elec_rad=2 * math.pi * 5 / 288) == (5, 288)
    assert count_period(pole_pairs=1, resolution_elec_rad=1.0) is None      # 2π: irrational


def staircase_capture(pole_pairs: int, decimation: int, mech_revs: float, *, phi=0.1):
    """The torque of eq 7 along a turning rotor whose firmware angle is the decimated count."""
    rate, speed_rps = 20_000.0, 2.0
    time_s = np.arange(int(mech_revs / speed_rps * rate)) / rate
    mech = 2 * np.pi * speed_rps * time_s + 1e-4
    counts = np.floor(mech * 7200 / (2 * np.pi))
    used = counts - np.mod(counts, decimation)
    theta_d = used * 2 * np.pi / 7200 * pole_pairs
    torque = np.cos(pole_pairs * mech - theta_d + phi)
    return Capture({"time_s": time_s, "rotor_angle_mech_rad": mech, "torque_nm": torque},
                   meta={"pole_pairs": pole_pairs})


def test_the_count_order_is_a_whole_line_over_the_common_period_and_smeared_over_one_revolution():
    capture = staircase_capture(5, 25, mech_revs=4.05)
    resolution = 2 * math.pi * 5 * 25 / 7200
    expected = count_order_amplitude_pu(resolution, 0.1)        # eq 7 over one count
    over_period = analyze_capture(capture, max_order=360, period_revolutions=5)
    assert over_period.revolutions == 4
    assert over_period.amplitude_nm[288 - 1] / abs(over_period.mean_torque_nm) == \
        pytest.approx(expected, rel=0.02)
    one_rev = analyze_capture(capture, max_order=360)
    smeared = one_rev.amplitude_nm[58 - 1] / abs(one_rev.mean_torque_nm)
    assert smeared < 0.5 * expected                             # what the plan judged before


def test_a_non_whole_order_is_never_rounded():
    plan = PointPlan(source="encoder", injection={"encoder_decimation": 25}, speed_rpm=12.0,
                     current_a=20.0, rule=test_encoder.RULE)
    with pytest.raises(InputError, match="not a whole order"):
        analysed_order(57.6, plan)
    assert analysed_order(57.6, dataclasses.replace(plan, period_revolutions=5)) == 288


def test_the_encoder_plan_analyses_a_10_pole_motor_over_its_period_and_refuses_what_it_cannot(
        tmp_path):
    config = bench_with(tmp_path, TEN_POLE)
    for decimation, period in ((25, 5), (50, 5), (100, 5)):
        plan = test_encoder.plan(config, {"encoder_decimation": decimation})
        assert plan.period_revolutions == period
        assert plan.revolutions * plan.period_revolutions >= test_encoder.REVOLUTIONS
        assert not problems(plan, config), problems(plan, config)
    # 14 poles: 288 over 7 revolutions, and the Nyquist order counted over that period
    fourteen = bench_with(tmp_path, TEN_POLE | {"pole_count": 14})
    plan = test_encoder.plan(fourteen, {"encoder_decimation": 25})
    assert plan.period_revolutions == 7 and not problems(plan, fourteen), problems(plan, fourteen)
    # the same point over one revolution is refused with the reason, never judged smeared
    one_rev = dataclasses.replace(test_encoder.plan(config, {"encoder_decimation": 25}),
                                  period_revolutions=1, revolutions=4)
    assert any(r.startswith("order not whole") for r in problems(one_rev, config))
    # a decimation that does not divide the counts: 3600 over 7 revolutions, beyond the band
    table_i = bench_with(tmp_path, {})
    refused = test_encoder.plan(table_i, {"encoder_decimation": 7})
    reasons = problems(refused, table_i)
    assert any("order 3600, beyond the analysed band" in r for r in reasons), reasons
