"""A characterisation that goes stale is repeated (issue 29 Build 4): the winding measured again
before a plan, on a simulated bench whose winding warms (``[simulation.actual]``) and on one that
does not."""

import pytest

from hil.bench import Bench
from hil.characterisation.identify import Identified
from hil.characterisation.recheck import SECTION, drifted, recheck_winding
from hil.characterisation.stage import run_stage
from hil.config import default_sim_bench
from hil.measurement import PointPlan, _acquire
from hil.record import RunRecord

#: the winding's steady rise at 20 A: +64 % (τ = 0.5 s: it warms within a few captures)
WARMING = {"winding_time_constant_s": 0.5, "winding_rise_pu_per_a2": 0.0016}


def _r(value, u):
    return Identified("phase_resistance_ohm", value, u, "ohm", "test")


def test_drift_is_judged_against_both_uncertainties():
    assert not drifted(_r(0.055, 0.001), _r(0.0578, 0.001))      # 2.8 mΩ ≤ √8 mΩ
    assert drifted(_r(0.055, 0.001), _r(0.0579, 0.001))
    assert drifted(_r(0.055, 0.0), _r(0.0549, 0.0))             # no U: any change


def _opened(tmp_path, actual=None):
    config = default_sim_bench()
    if actual:
        config = config.with_overrides({"simulation": {"actual": actual}})
    bench = Bench.open(config, seed=3)
    record = RunRecord.create(tmp_path, config, bench.identities())
    run_stage(bench, record)
    return bench, record


def _heat(bench, record, current_a, seconds):
    """Drive ``current_a`` for about ``seconds`` (a plan at a higher current than the stage's)."""
    op = bench.config.operating_point
    plan = PointPlan(source="characterisation", injection={}, speed_rpm=op.speed_rpm,
                     current_a=current_a, current_angle_rad=0.0, kind="self_check", rule=None,
                     drive_enabled=True, sample_rate_hz=2000.0,
                     revolutions=max(2, round(seconds * abs(op.speed_rpm) / 60
                                              * bench.config.motor.pole_pairs)))
    _acquire(bench, record, f"heat-{current_a:g}A", plan, bench.config.motor.pole_pairs)


def test_a_warmed_winding_is_characterised_again_and_the_plans_read_it(tmp_path):
    bench, record = _opened(tmp_path, WARMING)
    try:
        held = bench.characterisation.get("phase_resistance_ohm")
        history = []
        _heat(bench, record, 20.0, 2.0)
        entry = recheck_winding(bench, record, "dead_time", history)
        assert entry["decision"] == "re-characterised", entry
        assert "phase_resistance_ohm" in entry["drifted"]
        now = bench.characterisation.get("phase_resistance_ohm")
        assert now.value > held.value + held.expanded + now.expanded     # it warmed
        assert bench.config.motor.phase_resistance_ohm == now.value      # what the plans read
        assert bench.stated_config.motor == default_sim_bench().motor    # the file is kept
        assert bench.characterisation.get("ke_v_s_per_rad") is not None  # ψ kept
        assert record.data[SECTION]["rechecks"] == history
        speed = abs(bench.characterisation.point.speed_rpm)
        assert (record.path / "captures"
                / f"characterisation-recheck-1-dead_time-{speed:.0f}rpm.npz").exists()
    finally:
        record.finish("complete")
        bench.close()


def test_a_winding_that_stays_as_characterised_is_confirmed(tmp_path):
    bench, record = _opened(tmp_path)
    try:
        before = bench.config
        history = []
        for plan in ("dc_offset", "encoder"):
            entry = recheck_winding(bench, record, plan, history)
            assert entry["decision"] == "confirmed", entry
        assert bench.config == before
        assert [e["before_plan"] for e in record.data[SECTION]["rechecks"]] == ["dc_offset",
                                                                               "encoder"]
    finally:
        record.finish("complete")
        bench.close()


def test_the_capture_rate_spreads_the_sampling_phases_over_the_revolutions():
    from hil.characterisation.sampling import (MAX_GAP_REVOLUTIONS, SAMPLE_RATE_HZ, phase_gap,
                                               sample_rate_hz)

    assert phase_gap(197.975, 8) == pytest.approx(0.825)     # Table I 1200 rpm at 7919 Hz
    assert phase_gap(380.496, 16) > 0.4                      # p10 250 rpm at 7927 Hz: 2 phases
    assert sample_rate_hz(1200.0, 2, 8) != SAMPLE_RATE_HZ
    for revolutions in (8, 16):
        for speed_rpm in (-2475.0, -500.0, 37.0, 250.0, 1200.0, 1600.0):
            for pole_pairs in (1, 2, 4, 5, 7):
                rate = sample_rate_hz(speed_rpm, pole_pairs, revolutions)
                per_rev = rate * 60.0 / (abs(speed_rpm) * pole_pairs)
                assert phase_gap(per_rev, revolutions) <= MAX_GAP_REVOLUTIONS / revolutions
                assert abs(rate - SAMPLE_RATE_HZ) <= 1000 and rate == int(rate)
                assert all(int(rate) % k for k in range(2, 90))       # prime
    assert sample_rate_hz(0.0, 4, 16) == SAMPLE_RATE_HZ


def test_an_electrical_frequency_of_one_hertz_takes_the_narrowest_gap_there_is():
    from hil.characterisation.sampling import phase_gap, sample_rate_hz

    rate = sample_rate_hz(30.0, 2, 16)            # f_e = 1 Hz: every whole rate is whole
    assert phase_gap(rate / 1.0, 16) == pytest.approx(1.0)
    assert rate == 7919.0                         # the nearest, since all are alike


def test_a_voltage_beyond_the_daq_is_rechecked_slower_or_said_not_rechecked(monkeypatch):
    from types import SimpleNamespace

    import hil.characterisation.stage as stage
    from hil.characterisation.recheck import _winding_capture

    speeds = []

    def clipped_above(limit):
        def capture(bench, record, name, plan, pole_pairs):
            speeds.append(plan.speed_rpm)
            return "beyond vab_v" if abs(plan.speed_rpm) > limit else SimpleNamespace(name=name)
        return capture

    from hil.config import OperatingPoint

    point = OperatingPoint(speed_rpm=-1000.0, current_a=5.0)
    monkeypatch.setattr(stage, "voltage_capture", clipped_above(700.0))
    got = _winding_capture(None, None, "characterisation-recheck-1-x", point, 2)
    assert speeds == [-1000.0, -600.0] and got.name.endswith("-600rpm")
    speeds.clear()
    monkeypatch.setattr(stage, "voltage_capture", clipped_above(100.0))
    reason = _winding_capture(None, None, "characterisation-recheck-1-x", point, 2)
    assert speeds == [-1000.0, -600.0, -350.0]
    assert reason == "beyond vab_v; beyond vab_v; beyond vab_v"
