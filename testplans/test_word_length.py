"""Controller word length (paper III-B, eqs 10-14). The paper gives only a worst-case bound
10/2^(n-1), which a drive ignoring the injection also meets; the plan judges against the derived
two-sided truncation-bias model of hil.model.word_length (order 1 where it dominates) and checks
the sweep's slope, and records the paper's bound beside each point."""

import pytest

from ripple_hil_testplans import conditions as c
from ripple_hil_testplans.sensitivity import check_sensitivity

pytestmark = pytest.mark.ripple_source("word_length")

#: Tolerance of the sweep's slope (measured/expected, 1 for a correct drive). Calibrated out of
#: sample (studies/pwm_calibration.py; hil/model/README.md): on the calibration set (Table I,
#: 4 points incl. reverse, 2 seeds) the slopes were 0.980–1.186 with U ≤ 0.096, so
#: max(|s − 1| + U) = 0.28, rounded up to ±0.30; checked on the holdout set (two other motors,
#: other points and seeds). It replaces the ±0.5 derived-range slope tolerance of session 3 (set
#: from the models' stated ranges, not from data), which a drive applying half the word-length
#: effect passed (0.538 ± 0.017); that drive now fails.
SLOPE_TOL = 0.30
#: Validity region of the derived model, from the same study: within its range on Table I
#: (L/R = 0.70 ms) and on an 8-pole 48 V motor (L/R = 2.5 ms), but 1.1–1.41× its value on a
#: 2-pole 24 V motor with L/R = 0.30 ms (4 of 12 points beyond its +20 %; cause not found). A
#: motor whose electrical time constant is below the smallest validated one is not determinable
#: here.
MIN_TIME_CONSTANT_S = 0.7e-3


def outside_region(config) -> str | None:
    """Why the word-length model is not validated for this bench's motor, or None."""
    motor = config.motor
    tau = motor.phase_inductance_h / motor.phase_resistance_ohm
    if tau < MIN_TIME_CONSTANT_S * (1 - 1e-6):
        return (f"word_length: the motor's L/R = {1e3 * tau:.2g} ms is below the "
                f"{1e3 * MIN_TIME_CONSTANT_S:.2g} ms down to which the derived model is "
                "validated (hil/model/README.md)")
    return None


#: Below this predicted order-1 pk-pk (the bias terms alone, pu of the mean torque) the order is
#: not judged, only the magnitude: 3 x the rule's bench-floor allowance (0.001 pu), since the
#: drive's own floor has orders of its own that dominate a ripple this small (1500 rpm, 30 A,
#: 12 bits: 0.25 % measured vs 0.26 % predicted, dominant order 3 from the floor near the
#: voltage limit, order 1 13.7 %; Table I at 1538 rpm, 20 A, 12 bits: order 1 predicted at
#: 0.12 %, dominant order 3). It is the order-1 part that must stand above the floor to
#: dominate, not the total with its broadband part (which was 0.33 % predicted there).
SIGNATURE_FLOOR_PU = 3 * c.DERIVED_RANGE_RULE.abs_tol_pu
PREDICTION = {"model": "derived", "max_order": 48, **c.WORD_LENGTH_FIRMWARE}


def prediction_params(config) -> dict:
    """The derived model's inputs at this bench: the firmware facts, and the loop and
    transducer the bench file states (the computed-I_q error reaches the torque reading through
    them, hil.model.word_length "Loop and transducer"); a bench file without the loop keeps
    the ideal-regulation form."""
    params = dict(PREDICTION, transducer_bandwidth_hz=config.torque.bandwidth_hz)
    drive = config.drive
    if drive.current_loop_bandwidth_hz is not None and drive.current_loop_delay_s is not None:
        params.update(c.current_loop(config))
    return params


def rule_at(config, injection):
    """The decision rule at this point: the derived-range rule, its order check dropped where
    the predicted order-1 ripple is below SIGNATURE_FLOOR_PU."""
    import dataclasses

    from hil.model import predict

    op = config.operating_point
    # beyond the voltage limit the point is refused by its validity region (hil.validity), on
    # the stated file or on the bench as characterised: building it must not refuse the run
    point = config.model_point(op.speed_rpm, op.current_a, op.current_angle_rad,
                               allow_beyond_voltage_limit=True)
    predicted = predict("word_length", point, **injection,
                        **prediction_params(config)).extras["order1_pk_pk_pu"]
    if predicted < SIGNATURE_FLOOR_PU:
        return dataclasses.replace(c.DERIVED_RANGE_RULE, check_signature=False)
    return c.DERIVED_RANGE_RULE


#: Orders the word-length point analyses (its band; the model's max_order is the same).
MAX_ORDER = PREDICTION["max_order"]


def sample_rate_hz(config) -> float:
    """The capture rate: ``POINTS_PER_PERIOD`` samples per period of the highest analysed order
    at the bench's electrical frequency (rounded up to 500 Hz, at least 1 kHz), *not* capped at
    the default 20 kHz (``PointPlan.capture_rate_hz``). At 2475 rpm on an 8-pole motor the cap
    left 121 samples per revolution for orders up to 48, the resampling's interpolation
    correction lifted the noise of the high orders and the pk-pk's U reached 30 % of the value
    (10 bits: 0.0134 ± 0.0041 pu), wider than the range's 20 % below the order-1 terms: a
    correct drive read "conditional pass". The samples per point stay the same at any speed
    (8 revolutions × 480); the DAQ's own rate limit is checked by the pre-flight."""
    import math

    from hil.measurement import POINTS_PER_PERIOD

    op = config.operating_point
    elec_hz = abs(op.speed_rpm) / 60.0 * config.motor.pole_pairs
    return float(max(1000.0, math.ceil(elec_hz * MAX_ORDER * POINTS_PER_PERIOD / 500.0) * 500.0))


#: The shortest capture, s: 8 revolutions at 500 rpm on Table I (the calibration's default
#: point, 0.24 s). The truncation noise that changes between revolutions is averaged over time,
#: not over revolutions: at 2475 rpm on 8 poles 8 revolutions last 48 ms and the pk-pk's
#: residual-noise bias (0.0028 pu at 10 bits) took U to 30 % of the value.
MIN_CAPTURE_S = 8 / (500.0 / 60.0 * 2)


def revolutions(config) -> int:
    """Electrical revolutions of a point: the default 8, more where 8 last less than
    MIN_CAPTURE_S."""
    import math

    op = config.operating_point
    elec_hz = abs(op.speed_rpm) / 60.0 * config.motor.pole_pairs
    return max(8, math.ceil(MIN_CAPTURE_S * elec_hz))


def plan(config, injection):
    return c.point(config.operating_point, "word_length", injection, rule_at(config, injection),
                   prediction_params=prediction_params(config), max_order=MAX_ORDER,
                   sample_rate_hz=sample_rate_hz(config), revolutions=revolutions(config),
                   expectation="judged against the derived truncation-bias model (two-sided, its "
                               "own stated range): two's-complement truncation is biased by "
                               "-1/2 LSB, which acts like a dc offset on both current sensors "
                               "(order-1 ripple; the order is judged where the ripple is at "
                               "least 3x the bench floor); the paper's worst-case bound "
                               "10/2^(n-1) is recorded beside it "
                               "(prediction.extras.paper_pk_pk_pu)")


@pytest.mark.parametrize("injection", c.WORD_LENGTH_SWEEP, ids=c.sweep_id)
def test_word_length(measure, bench, injection):
    reason = outside_region(bench.config)
    if reason:
        from hil.outcome_kinds import not_determinable

        pytest.skip(not_determinable(reason))
    outcome = measure(plan(bench.config, injection))
    assert outcome.passed, outcome.summary()


def test_word_length_sensitivity(record):
    """The sweep's measured ripple scales with the word length as the derived model says."""
    result = check_sensitivity(record, "word_length", SLOPE_TOL)
    assert result["accepted"], result["statement"]
