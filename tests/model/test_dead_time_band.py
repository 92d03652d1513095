"""The dead-time plan's band and phase check against the simulated drive, off the calibration set.

Captures as the plan captures (studies/dead_time_calibration.py), judged with the plan's rule
(``DEAD_TIME_RULE``, guarded: |m − p| ≤ rel_tol·p + abs_tol − U) and ``phase_judge`` (None: the order-6 phase is not resolved).
"""

import math
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "studies"))

import dead_time_calibration as study  # noqa: E402
from hil.measurement import PointPlan  # noqa: E402
from hil.model import OperatingPoint, predict  # noqa: E402
from ripple_hil_testplans.test_dead_time import (DEAD_TIME_RULE, order6_amplitude_check,  # noqa: E402
                                                 phase_judge)


def judge(point, *, model_scale=1.0, transducer_hz=1000.0, bench=None):
    """(pk-pk guarded pass, phase check) of one twin capture against the model × scale."""
    motor = study.MOTORS[point.motor]
    op = OperatingPoint(speed_rpm=point.speed_rpm, current_a=point.current_a, motor=motor)
    prediction = predict("dead_time", op, dead_time_s=point.dead_time_s,
                         model="current_clamping", transducer_bandwidth_hz=1000.0, **study.LOOP)
    plan = PointPlan(source="dead_time", injection={"dead_time_s": point.dead_time_s},
                     speed_rpm=point.speed_rpm, current_a=point.current_a)
    result = study.capture(point, plan, transducer_bandwidth_hz=transducer_hz)
    nameplate = op.mean_torque_nm
    measured = result.pk_pk_nm / nameplate
    expanded = result.uncertainty.expanded_pu * abs(result.mean_torque_nm) / nameplate
    predicted = model_scale * prediction.pk_pk_nm / nameplate
    pk_pk_ok = abs(measured - predicted) <= (DEAD_TIME_RULE.rel_tol * predicted
                                             + DEAD_TIME_RULE.abs_tol_pu - expanded)
    return pk_pk_ok, phase_judge(result, prediction, plan, bench)


HOLDOUT = [study.Point("B", -400.0, 8.0, 3e-6, 16), study.Point("TableI", -750.0, 15.0, 3e-6, 38),
           study.Point("B", 900.0, 25.0, 3e-6, 22)]


@pytest.mark.parametrize("point", HOLDOUT, ids=lambda p: f"{p.motor}-{p.speed_rpm:g}rpm")
def test_correct_drive_passes_on_holdout_points(point):
    assert point not in study.calibration_set()
    pk_pk_ok, phase = judge(point)
    assert pk_pk_ok
    assert phase is not None and phase.guarded_pass, phase


@pytest.mark.parametrize("point", HOLDOUT[:2], ids=lambda p: f"{p.motor}-{p.speed_rpm:g}rpm")
def test_model_twice_too_large_or_half_fails(point):
    assert not judge(point, model_scale=2.0)[0]
    assert not judge(point, model_scale=0.5)[0]


def test_transducer_lagging_1ms_more_than_stated_fails_the_phase_check():
    """Bench file: 1 kHz first order (τ = 0.16 ms); the transducer lags 1 ms more (τ = 1.16 ms,
    137 Hz). At 500 rpm / 20 A, 4 µs the pk-pk reads ≈ 20 % low (inside ±35 %) but the order-6
    phase moves by ≈ 30° against ±5°."""
    tau = 1.0 / (2 * math.pi * 1000.0) + 1e-3
    point = study.Point("TableI", 500.0, 20.0, 4e-6, 3)
    pk_pk_ok, phase = judge(point, transducer_hz=1.0 / (2 * math.pi * tau))
    assert phase is not None and not phase.guarded_pass, phase
    assert math.degrees(phase.difference_rad) < -20.0
    _, right = judge(point)
    assert right is not None and right.guarded_pass, right.reason


def test_no_phase_verdict_without_a_stated_transducer_bandwidth():
    """A bench file without [torque] bandwidth_hz: the transducer's phase lag is unknown, so the
    order-6 phase is not judged (the point is then not determinable); it was judged against a
    model with an ideal transducer and rejected a correct drive at −700 rpm / 12 A (+0.161 rad
    against ±0.087)."""
    from types import SimpleNamespace

    def bench(bandwidth_hz):
        return SimpleNamespace(config=SimpleNamespace(torque=SimpleNamespace(
            bandwidth_hz=bandwidth_hz)))

    point = HOLDOUT[0]
    assert judge(point, bench=bench(None))[1] is None
    stated = judge(point, bench=bench(1000.0))[1]
    assert stated is not None and stated.guarded_pass, stated


def amplitude_verdict(point, applied_fraction=1.0):
    """The plan's order-6 amplitude check of a twin whose drive applies ``applied_fraction`` of
    the commanded dead time, against the model at the commanded one."""
    from dataclasses import replace

    motor = study.MOTORS[point.motor]
    op = OperatingPoint(speed_rpm=point.speed_rpm, current_a=point.current_a, motor=motor)
    prediction = predict("dead_time", op, dead_time_s=point.dead_time_s,
                         model="current_clamping", transducer_bandwidth_hz=1000.0, **study.LOOP)
    applied = replace(point, dead_time_s=applied_fraction * point.dead_time_s)
    plan = PointPlan(source="dead_time", injection={"dead_time_s": applied.dead_time_s},
                     speed_rpm=point.speed_rpm, current_a=point.current_a)
    return order6_amplitude_check(study.capture(applied, plan), prediction)


#: off the calibration set: other motors (10-pole 48 V; 2-pole 24 V 80 µH at low current and
#: high speed, the holdout's worst point), reverse rotation, other seeds
AMPLITUDE_POINTS = [study.Point("B", -400.0, 8.0, 3e-6, 16),
                    study.Point("C", 1300.0, 5.0, 3e-6, 32),
                    study.Point("TableI", -750.0, 15.0, 3e-6, 38)]


@pytest.mark.parametrize("point", AMPLITUDE_POINTS, ids=lambda p: f"{p.motor}-{p.speed_rpm:g}rpm")
def test_order6_amplitude_passes_a_correct_drive_and_fails_one_applying_70_percent(point):
    """Issue 21 (dt brief item 3): a drive that applies 70 % of the commanded dead time sat
    inside the ±35 % pk-pk band; the order-6 amplitude (±15 %, guarded) fails it wherever the
    correct drive passes."""
    assert point not in study.calibration_set()
    right = amplitude_verdict(point)
    assert right is not None and right["passed"], right
    wrong = amplitude_verdict(point, applied_fraction=0.7)
    assert wrong is not None and not wrong["passed"], wrong
    assert wrong["measured"] / wrong["expected"] < 0.8


def test_phase_zone_widens_by_the_bench_floor_and_still_fails_a_lagging_transducer():
    """The order-6 phase zone is ±5° + asin(floor/2 / A_6): on the simulated bench (floor
    0.001 N·m pk-pk) at Table I 500 rpm / 20 A, 4 µs (A_6 ≈ 0.0036 N·m) ≈ 13°; the transducer
    lagging 1 ms more than stated is ≈ 30° off and still fails, the stated one passes."""
    from hil.analysis.decision import decide_phase
    from ripple_hil_testplans.test_dead_time import phase_tolerance_rad

    point = study.Point("TableI", 500.0, 20.0, 4e-6, 3)
    op = OperatingPoint(speed_rpm=point.speed_rpm, current_a=point.current_a)
    prediction = predict("dead_time", op, dead_time_s=point.dead_time_s,
                         model="current_clamping", transducer_bandwidth_hz=1000.0, **study.LOOP)
    tolerance = phase_tolerance_rad(prediction, 0.001)
    assert math.radians(12.0) < tolerance < math.radians(14.5)
    assert phase_tolerance_rad(prediction, 0.0) == pytest.approx(math.radians(5.0))
    plan = PointPlan(source="dead_time", injection={"dead_time_s": point.dead_time_s},
                     speed_rpm=point.speed_rpm, current_a=point.current_a)
    tau = 1.0 / (2 * math.pi * 1000.0) + 1e-3
    lagging = study.capture(point, plan, transducer_bandwidth_hz=1.0 / (2 * math.pi * tau))
    assert not decide_phase(lagging, 6, prediction.extras["order6_phase_rad"],
                            tolerance_rad=tolerance).guarded_pass
    assert decide_phase(study.capture(point, plan), 6, prediction.extras["order6_phase_rad"],
                        tolerance_rad=tolerance).guarded_pass


def test_the_low_current_high_speed_wrong_rejection_is_gone():
    """Issue 21's validity study: Table I at 1000 rpm / 5 A, 2 µs read 0.0367 pu against a
    predicted 0.0277 (+30 %, a wrong rejection). With the PWM ripple at the crossings the model
    predicts ≈ 0.038 and the correct drive passes the pk-pk band, the order-6 amplitude and the
    phase (another seed than the calibration's)."""
    point = study.Point("TableI", 1000.0, 5.0, 2e-6, 5)
    pk_pk_ok, phase = judge(point)
    assert pk_pk_ok
    assert phase is not None and phase.guarded_pass, phase
    amplitude = amplitude_verdict(point)
    assert amplitude is not None and amplitude["passed"], amplitude
