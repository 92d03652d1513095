"""The dwell term of a coarse encoder (hil.diagnosis.dwell): its forward model on known cases,
and on the twin the offsets' uncertainty covering the error the dwell causes."""

import math

import numpy as np
import pytest

from hil.diagnosis import dwell
from hil.diagnosis import signatures as sig
from hil.diagnosis.twin_proof import HiddenFaults, prove, twin_config, twin_setup
from ripple_hil_testplans import diagnosis_design as design

SETUP = twin_setup(twin_config(HiddenFaults()))
WIDTH = math.radians(20.0)


def _op(speed_rpm=400.0):
    return sig.operating_point(speed_rpm, 10.0, WIDTH / 2, SETUP)


def test_a_pulse_dc_current_is_the_loop_rejection_of_its_mean_voltage():
    """The dc of the current: the pulse's mean (width/2π volts per volt) in the leg's space-vector
    direction, through the loop's disturbance rejection at −ω_e (a stationary dc)."""
    op = _op()
    start = dwell.dwell_starts_rad(op, "a", WIDTH)[0]
    _, dc = dwell.dwell_pulse_orders(op, SETUP, "a", start, WIDTH)
    vector = sig.loop_rejection(-op.elec_speed_rad_s, op,
                                2 * math.pi * SETUP.current_loop_bandwidth_hz,
                                SETUP.current_loop_delay_s) * (2 / 3) * WIDTH / (2 * math.pi)
    assert dc == pytest.approx(complex(vector.real, -0.5 * vector.real
                                       + 0.5 * math.sqrt(3) * vector.imag), rel=1e-9)


def test_half_wave_symmetry_decides_which_torque_orders_a_leg_dwell_pair_makes():
    """Both dwells of a leg with the same error (what breaks the half-wave symmetry): even phase
    harmonics only, so odd torque orders (1, 3) and none at order 2; with opposite errors
    (half-wave symmetric, what the average model assumes) the order-1 torque vanishes."""
    op = _op()
    first, second = (dwell.dwell_pulse_orders(op, SETUP, "b", s, WIDTH)[0]
                     for s in dwell.dwell_starts_rad(op, "b", WIDTH))
    same, opposite = first + second, first - second
    assert abs(same[1]) > 1e-5 and abs(same[2]) < 1e-9 * abs(same[1])
    assert abs(opposite[1]) < 1e-9 * abs(same[1]) and abs(opposite[2]) > 1e-5


def test_leg_loss_is_the_average_models_epsilon():
    assert dwell.leg_loss_v(2e-6, 20_000.0, 12.0) == pytest.approx(0.48)
    assert dwell.leg_loss_v(-1e-6, 20_000.0, 12.0) == 0.0


def test_offset_with_coarse_encoder_and_dead_time_is_within_its_stated_uncertainty():
    """The isolated case of the README: offset 0.3 A, 20° electrical per count, 2 µs dead time.
    The estimate is off by ≈ 2.7 mA (the dwell); before the dwell term its U (k = 2) was
    ≈ 1.3 mA, so the check failed; with it the error is within U, and the output says the
    component is a stated bound."""
    faults = HiddenFaults(ia_offset_a=0.3, dead_time_s=2e-6, encoder_decimation=200)
    case = prove(faults, design.design_points(), revolutions_elec=design.REVOLUTIONS_ELEC,
                 sample_rate_hz=design.SAMPLE_RATE_HZ, max_mech_order=design.MAX_MECH_ORDER,
                 seed=1)
    checks = {c["name"]: c for c in case.checks}
    a = checks["ia_offset_a"]
    assert abs(a["estimate"] - a["hidden"]) > 1.5e-3          # the dwell's error is there
    assert a["covered"], a
    assert checks["ib_offset_a"]["covered"]
    bound = case.diagnosis.encoder["offset_dwell_bound"]
    assert bound["applied"] and bound["kind"].startswith("stated bound")
    assert any("stated bound, not a model" in note for note in case.diagnosis.notes)


def test_no_dwell_term_without_a_count_line():
    """Decimation 1 (no count line in band): no dwell term, the offsets' U is the fit's alone."""
    faults = HiddenFaults(ia_offset_a=0.3, dead_time_s=2e-6)
    case = prove(faults, design.design_points(), revolutions_elec=design.REVOLUTIONS_ELEC,
                 sample_rate_hz=design.SAMPLE_RATE_HZ, max_mech_order=design.MAX_MECH_ORDER,
                 seed=1)
    assert "offset_dwell_bound" not in case.diagnosis.encoder
    assert not any("stated bound" in note for note in case.diagnosis.notes)


@pytest.mark.parametrize("bound_s", [-1e-6, math.nan, math.inf, 2.5e-5, 5e-5])
def test_a_dead_time_bound_of_half_a_pwm_period_or_more_is_refused(bound_s):
    """A dead time ≥ half the PWM period (25 µs at 20 kHz) leaves no commanded pulse; such a
    bound would make ε ≥ V_dc/2 and the offsets' U meaningless (was accepted up to 100 µs)."""
    from hil.errors import InputError

    with pytest.raises(InputError, match=r"dead_time_bound_s=.*below half a PWM period"):
        sig.DriveSetup(dead_time_bound_s=bound_s, pwm_frequency_hz=20_000.0)
    assert sig.DriveSetup(dead_time_bound_s=2.4e-5).dead_time_bound_s == 2.4e-5
    assert sig.DriveSetup(dead_time_bound_s=9e-5, pwm_frequency_hz=2000.0).dead_time_bound_s \
        == 9e-5


def test_the_fallback_dead_time_bound_is_never_zero_while_the_term_says_applied():
    """No dead time hidden: the nuisance estimate is about zero (or below), so × 3 bounds
    nothing; the fallback also takes the fit's own k = 2 interval, so an applied term has a
    non-zero ε (it said "applied" with ε = 0 before), or it is not applied and says why."""
    faults = HiddenFaults(ia_offset_a=0.3, dead_time_s=0.0, encoder_decimation=200)
    case = prove(faults, design.design_points(), revolutions_elec=design.REVOLUTIONS_ELEC,
                 sample_rate_hz=design.SAMPLE_RATE_HZ, max_mech_order=design.MAX_MECH_ORDER,
                 seed=1)
    bound = case.diagnosis.encoder["offset_dwell_bound"]
    if bound["applied"]:
        assert bound["dead_time_bound_us"] > 0 and bound["leg_error_bound_v"] > 0, bound
        assert "fit interval" in bound["dead_time_bound_from"]
    else:
        assert any("bounds nothing above zero" in note for note in case.diagnosis.notes)
