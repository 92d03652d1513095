"""The dyno is never left at a speed where the PWM carrier is locked to the rotor
(hil.carrier_lock): the least change that makes the carrier walk, recorded beside the nominal."""

import numpy as np
import pytest

from hil.carrier_lock import (MAX_NUDGE_PU, MAX_PHASE_GAP_PERIODS, carrier_phase_gap,
                              unlocked_speed_rpm)


def test_the_gap_of_a_locked_and_of_a_walking_carrier():
    assert carrier_phase_gap(500.0, 20) == pytest.approx(1.0)          # every revolution alike
    assert carrier_phase_gap(480.5, 20) == pytest.approx(0.5)          # two phases
    assert carrier_phase_gap(500.05, 20) == pytest.approx(0.05)        # a period in 20 turns
    assert carrier_phase_gap(500.0 + (5 ** 0.5 - 1) / 2, 20) < 0.1     # golden: spread


@pytest.mark.parametrize("speed_rpm, pole_pairs", [(1200.0, 2), (500.0, 2), (250.0, 4),
                                                   (-500.0, 5), (1200.0, 5), (1000.0, 2)])
def test_a_locked_speed_moves_by_the_least_that_unlocks_it(speed_rpm, pole_pairs):
    revolutions = 20
    moved = unlocked_speed_rpm(speed_rpm, pole_pairs, 20_000.0, revolutions)
    ratio = lambda rpm: 20_000.0 / (abs(rpm) / 60.0 * pole_pairs)      # noqa: E731
    assert carrier_phase_gap(ratio(speed_rpm), revolutions) > MAX_PHASE_GAP_PERIODS
    assert carrier_phase_gap(ratio(moved), revolutions) <= MAX_PHASE_GAP_PERIODS
    assert np.sign(moved) == np.sign(speed_rpm)
    change = abs(moved / speed_rpm - 1.0)
    assert 0 < change <= MAX_NUDGE_PU
    # nothing closer would do: every smaller change on either side leaves the carrier locked
    for smaller in np.arange(1, round(change / 1e-5)) * 1e-5:
        for sign in (1.0, -1.0):
            assert carrier_phase_gap(ratio(speed_rpm * (1 + sign * smaller)),
                                     revolutions) > MAX_PHASE_GAP_PERIODS


@pytest.mark.parametrize("speed_rpm, pole_pairs, revolutions", [(731.0, 3, 20),
                                                                (-2475.0, 4, 20),
                                                                (1000.0, 2, 1)])
def test_a_walking_carrier_or_a_single_revolution_is_left_alone(speed_rpm, pole_pairs,
                                                                revolutions):
    assert unlocked_speed_rpm(speed_rpm, pole_pairs, 20_000.0, revolutions) == speed_rpm


def test_the_record_keeps_the_nominal_speed_and_the_dyno_speed(tmp_path):
    from hil.bench import Bench
    from hil.config import default_sim_bench
    from hil.measurement import measure_point
    from hil.record import RunRecord
    from ripple_hil_testplans import conditions as c

    config = default_sim_bench()          # 500 rpm, 2 pole pairs: 1200 periods a revolution
    op = config.operating_point
    bench = Bench.open(config, seed=1)
    record = RunRecord.create(tmp_path, config, bench.identities())
    try:
        plan = c.point(op, "baseline", {}, c.BASELINE_RULE)
        measure_point(bench, record, "baseline-locked-speed", plan)
    finally:
        record.finish("complete")
        bench.close()
    entry = record.test("baseline-locked-speed")
    nominal, dyno = (entry["operating_point"]["speed_rpm"],
                     entry["operating_point"]["dyno_speed_setpoint_rpm"])
    assert nominal == op.speed_rpm and dyno != nominal
    assert abs(dyno / nominal - 1.0) <= MAX_NUDGE_PU
    pole_pairs = config.motor.pole_pairs
    assert carrier_phase_gap(20_000.0 / (dyno / 60 * pole_pairs), plan.revolutions) \
        <= MAX_PHASE_GAP_PERIODS


def test_the_self_check_judges_the_speed_against_the_dyno_setpoint_it_was_given(tmp_path):
    """The speed check compares the encoder's speed with the speed the dyno was commanded (moved
    off the lock), not the nominal one: a 0.5 % DAQ clock error must not hide behind a nudge of
    the same size. With the drive disabled there is no carrier and the dyno is not moved."""
    from hil.bench import Bench
    from hil.config import default_sim_bench
    from hil.measurement import measure_point
    from hil.record import RunRecord
    from ripple_hil_testplans import conditions as c

    config = default_sim_bench()
    op = config.operating_point
    bench = Bench.open(config, seed=1)
    record = RunRecord.create(tmp_path, config, bench.identities())
    try:
        measure_point(bench, record, "self-check", c.self_check_point(op))
        disabled = c.point(op, "self_check", {}, None, kind="self_check", current_a=0.0,
                           drive_enabled=False)
        measure_point(bench, record, "disabled", disabled)
    finally:
        record.finish("complete")
        bench.close()
    entry = record.test("self-check")
    dyno = entry["operating_point"]["dyno_speed_setpoint_rpm"]
    assert dyno != op.speed_rpm
    speed_check = next(ch for ch in entry["checks"] if ch["name"] == "speed")
    assert speed_check["expected"] == dyno and speed_check["passed"]
    assert abs(speed_check["measured"] - dyno) < abs(speed_check["measured"] - op.speed_rpm)
    assert record.test("disabled")["operating_point"]["dyno_speed_setpoint_rpm"] == op.speed_rpm


def test_the_lock_is_judged_over_the_analysed_periods():
    """The synchronous average groups by analysed periods of m electrical revolutions (encoder
    decimation that does not divide a revolution): 12 rpm on 5 pole pairs at 20 kHz is r = 20000
    a revolution — locked — and the carrier must walk from one *period* to the next."""
    from hil.carrier_lock import carrier_locked

    moved = unlocked_speed_rpm(12.0, 5, 20_000.0, 8, period_revolutions=5)
    per_period = 20_000.0 * 5 / (moved / 60 * 5)
    assert carrier_phase_gap(per_period, 8) <= MAX_PHASE_GAP_PERIODS
    assert not carrier_locked(moved, 5, 20_000.0, 8, period_revolutions=5)
    assert carrier_locked(12.0, 5, 20_000.0, 8, period_revolutions=5)


def test_a_speed_no_move_unlocks_is_kept_and_said_to_be_locked():
    """10 kHz, 5 pole pairs, 3000 rpm: 40 periods a revolution, and no move within 0.5 % spreads
    4 revolutions' carrier phases: the speed is kept and ``carrier_locked`` says so."""
    from hil.carrier_lock import carrier_locked

    assert unlocked_speed_rpm(3000.0, 5, 10_000.0, 4) == 3000.0
    assert carrier_locked(3000.0, 5, 10_000.0, 4)
    assert not carrier_locked(3000.0 * 1.003, 5, 10_000.0, 40)


def test_the_move_prefers_a_slower_speed():
    """Slower keeps the voltage headroom and the speed limit the pre-flight checked."""
    for speed_rpm, pole_pairs in ((500.0, 2), (1000.0, 2), (-500.0, 5)):
        moved = unlocked_speed_rpm(speed_rpm, pole_pairs, 20_000.0, 8)
        assert abs(moved) < abs(speed_rpm)
