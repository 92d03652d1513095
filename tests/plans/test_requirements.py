"""Requirements as data (hil.requirements): parsing, where a line applies, and its verdict on a
measured ripple of known content (analysed by hil.analysis, never computed by the line itself)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hil.analysis import analyze_capture
from hil.capture import Capture
from hil.errors import InputError
from hil.requirements import (Requirement, judge, load_requirements, requirement_from_dict)

EXAMPLE = __import__("pathlib").Path(__file__).parents[2] / "hil" / "examples" / "requirements.toml"


def synthetic_result(mean_nm=1.0, orders=None, revolutions=8, noise_nm=0.0, seed=0):
    """A capture of 500 rpm (pole pairs 2) with mean torque + Σ A_k cos(kθ), analysed."""
    orders = orders or {}
    rate, f_e = 20_000.0, 500 / 60 * 2
    time_s = np.arange(int((revolutions + 0.25) / f_e * rate)) / rate
    theta_m = 2 * math.pi * 500 / 60 * time_s
    torque = np.full_like(time_s, mean_nm)
    for k, amplitude in orders.items():
        torque += amplitude * np.cos(k * 2 * theta_m)
    torque += np.random.default_rng(seed).normal(0.0, noise_nm, time_s.size)
    capture = Capture({"time_s": time_s, "torque_nm": torque, "rotor_angle_mech_rad": theta_m},
                      meta={"pole_pairs": 2})
    return analyze_capture(capture, max_order=24)


def line(**overrides):
    table = {"id": "REQ-1", "name": "total ripple", "quantity": "pk_pk_pct", "limit": {"max": 3.0}}
    return requirement_from_dict(table | overrides)


def test_the_shipped_example_loads_with_one_demonstration_line():
    lines = load_requirements(EXAMPLE)
    assert len(lines) >= 4
    assert [r.id for r in lines if r.demonstration] == ["REQ-90"]


@pytest.mark.parametrize("table, message", [
    ({"name": "x", "quantity": "pk_pk_pct", "limit": {"max": 3}}, "missing key 'id'"),
    ({"id": "R", "name": "x", "quantity": "ripple", "limit": {"max": 3}}, "quantity"),
    ({"id": "R", "name": "x", "quantity": "pk_pk_pct", "limit": {}}, "limit"),
    ({"id": "R", "name": "x", "quantity": "pk_pk_pct", "limit": {"max": 1, "min": 2}}, "min 2.0 > max"),
    ({"id": "R", "name": "x", "quantity": "pk_pk_pct", "limit": {"max": 3}, "unit": "N*m"}, "unit"),
    ({"id": "R", "name": "x", "quantity": "order_amplitude_pct", "limit": {"max": 3}}, "order"),
    ({"id": "R", "name": "x", "quantity": "pk_pk_pct", "limit": {"max": 3}, "order": 2}, "order"),
    ({"id": "R", "name": "x", "quantity": "pk_pk_pct", "limit": {"max": 3}, "colour": 1}, "colour"),
    ({"id": "R", "name": "x", "quantity": "pk_pk_pct", "limit": {"max": float("nan")}}, "finite"),
    ({"id": "R", "name": "x", "quantity": "pk_pk_pct", "limit": {"max": 3}, "speed_rpm": [9, 1]},
     "low > high"),
    ({"id": "R", "name": "x", "quantity": "pk_pk_pct", "limit": {"max": 3}, "rule": "lenient"},
     "rule"),
])
def test_bad_lines_are_refused_naming_the_key(table, message):
    with pytest.raises(InputError, match=message):
        requirement_from_dict(table)


def test_duplicate_ids_and_bad_files_are_refused(tmp_path):
    twice = tmp_path / "twice.toml"
    twice.write_text('[[requirement]]\nid="A"\nname="a"\nquantity="pk_pk_pct"\nlimit={max=1}\n' * 2)
    with pytest.raises(InputError, match="given twice"):
        load_requirements(twice)
    with pytest.raises(InputError, match="does not exist"):
        load_requirements(tmp_path / "missing.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[[requirement]\n")
    with pytest.raises(InputError, match="not valid TOML"):
        load_requirements(bad)


def test_where_a_line_applies():
    req = line(source=["baseline", "ripple_map"], speed_rpm=[0, 1500], current_a=20,
               injected="none")
    point = {"source": "ripple_map", "speed_rpm": 800, "current_a": 20, "injection": {}}
    assert req.applies(**point)
    assert req.applies(**point | {"speed_rpm": -800})          # |speed|: either direction
    assert not req.applies(**point | {"speed_rpm": 2000})
    assert not req.applies(**point | {"current_a": 15})
    assert not req.applies(**point | {"source": "dc_offset"})
    assert not req.applies(**point | {"injection": {"ia_offset_a": 0.1}})
    production = line(injection={"encoder_decimation": 100})
    assert production.applies(source="encoder", speed_rpm=12, current_a=20,
                              injection={"encoder_decimation": 100})
    assert not production.applies(source="encoder", speed_rpm=12, current_a=20,
                                  injection={"hall_mode": True})


def test_pk_pk_verdicts_in_each_ilac_g8_zone():
    # 2 % pk-pk of order 6 on a 1 N·m mean: measured by the analysis, U from its scatter.
    result = synthetic_result(orders={6: 0.01}, noise_nm=0.002)
    measured = 100 * result.pk_pk_pu
    expanded = 100 * result.uncertainty.expanded_pu
    assert measured == pytest.approx(2.0, rel=0.05)
    assert expanded > 0
    assert judge(line(limit={"max": measured + 2 * expanded}), result)["decision"] == "pass"
    assert judge(line(limit={"max": measured + 0.5 * expanded}), result)["decision"] == \
        "conditional pass"
    assert judge(line(limit={"max": measured - 0.5 * expanded}), result)["decision"] == \
        "conditional fail"
    verdict = judge(line(limit={"max": measured - 2 * expanded}), result)
    assert verdict["decision"] == "fail" and not verdict["accepted"]
    # simple acceptance accepts the conditional pass, guarded acceptance does not
    cond = {"max": measured + 0.5 * expanded}
    assert judge(line(limit=cond, rule="simple"), result)["accepted"]
    assert not judge(line(limit=cond), result)["accepted"]
    # the record's line says when a conditional zone was not accepted, and by which rule
    assert judge(line(limit=cond), result)["statement"].endswith(
        "CONDITIONAL PASS, not accepted by the guarded rule")
    assert judge(line(limit=cond, rule="simple"), result)["statement"].endswith(
        "CONDITIONAL PASS")


def test_order_amplitude_rms_and_mean_torque_are_measured_quantities():
    result = synthetic_result(mean_nm=0.8, orders={2: 0.008, 6: 0.004})
    order2 = judge(line(quantity="order_amplitude_pct", order=2, limit={"max": 2.0}), result)
    assert order2["measured"] == pytest.approx(1.0, rel=1e-3)      # 0.008 / 0.8
    rms = judge(line(quantity="rms_pct", limit={"max": 2.0}), result)
    assert rms["measured"] == pytest.approx(100 * math.sqrt((0.008 ** 2 + 0.004 ** 2) / 2) / 0.8,
                                            rel=1e-3)
    mean = judge(line(quantity="mean_torque_nm", limit={"min": 0.9}), result,
                 torque_accuracy_nm=0.005)
    assert mean["measured"] == pytest.approx(0.8, rel=1e-6)
    assert mean["decision"] == "fail"
    assert mean["expanded_uncertainty"] == pytest.approx(2 * 0.005 / math.sqrt(3), rel=0.01)
    with pytest.raises(InputError, match="outside the analysed band"):
        judge(line(quantity="order_amplitude_pct", order=30, limit={"max": 1.0}), result)


def test_statement_names_id_limit_and_demonstration():
    result = synthetic_result(orders={6: 0.01})
    verdict = judge(Requirement(id="REQ-12", name="total ripple", quantity="pk_pk_pct",
                                limit_max=1.0, demonstration=True), result)
    assert verdict["statement"].startswith("REQ-12 total ripple ≤ 1 %: measured 2")
    assert verdict["statement"].endswith("FAIL (demonstration)")


def test_negative_speed_or_current_bounds_are_refused():
    with pytest.raises(InputError, match="magnitude"):
        line(speed_rpm=-500)
    with pytest.raises(InputError, match="magnitude"):
        line(current_a=[-5, 10])
