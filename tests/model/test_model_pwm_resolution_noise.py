"""The duty-quantisation noise model (hil.model.pwm_noise): its linear part against a direct
time-domain simulation of the same loop equations, its expectation against the simulated drive,
and its range excluding a drive whose counter is scaled (the defect the plan's noise check
exists to catch)."""

import math

import numpy as np
import pytest

from hil.analysis.nonsync import nonsynchronous_rms
from hil.errors import InputError
from hil.model import OperatingPoint
from hil.model.pwm_noise import (NOISE_RANGE_FACTORS, computation_delay_periods, loop_matrices,
                                 predict_noise, steady_phasor_peak_v, white_noise_rms_pu)
from hil.sim import DriveConfig, DriveTwin

PLAN_POINT = OperatingPoint(speed_rpm=500, current_a=20.0)  # the simulated bench's point
LOOP = {"current_loop_bandwidth_hz": 1600.0, "current_loop_delay_s": 75e-6,
        "transducer_bandwidth_hz": 1000.0, "pwm_frequency_hz": 20_000.0}


def direct_loop_rms_pu(counts, periods=60_000, substeps=8, seed=3):
    """The white-noise loop written out step by step (not through loop_matrices): uniform leg
    errors, PI integrator first, one period of computation delay, R-L plant and the transducer
    low-pass integrated in substeps; stationary q-axis RMS of the transducer reading."""
    motor, period = PLAN_POINT.motor, 1 / 20_000
    r, ind = motor.phase_resistance_ohm, motor.phase_inductance_h
    impedance = r + 1j * PLAN_POINT.elec_speed_rad_s * ind
    omega_c, w_t = 2 * math.pi * 1600, 2 * math.pi * 1000
    dt = period / substeps
    decay = np.exp(-impedance / ind * dt)
    gain = (1 - decay) / impedance
    lowpass = math.exp(-w_t * dt)
    rng = np.random.default_rng(seed)
    errors = rng.uniform(-12 / counts, 0, (periods, 3)) @ np.exp(
        1j * np.array([0, 2 * math.pi / 3, -2 * math.pi / 3])) * (2 / 3)
    current = integrator = command = reading = 0j
    out = np.empty(periods)
    for k in range(periods):
        sample = current
        applied = command + errors[k]
        for _ in range(substeps):
            current = decay * current + gain * applied
            reading = lowpass * reading + (1 - lowpass) * current
        integrator += omega_c * r * period * (-sample)
        command = omega_c * ind * (-sample) + integrator       # applied from the next period
        out[k] = reading.real
    return float(np.std(out[2000:])) / PLAN_POINT.current_a


def test_white_noise_covariance_matches_the_loop_run_step_by_step():
    a, b = loop_matrices(PLAN_POINT, 20_000.0, 1600.0, 1.0, 1000.0)
    # many revolutions: the synchronous share removed tends to 0, the stationary RMS remains
    model = white_noise_rms_pu(PLAN_POINT, 32, a, b, 100_000, 48, 20_000.0)
    assert model == pytest.approx(direct_loop_rms_pu(32), rel=0.05)


def twin_noise_pu(counts, revolutions=8, seed=1):
    """The simulated drive's non-synchronous transducer RMS at the plan's point and capture."""
    twin = DriveTwin(DriveConfig(), seed=seed)
    twin.set_injection(pwm_period_counts=counts)
    twin.speed_rpm, twin.current_command_a = PLAN_POINT.speed_rpm, PLAN_POINT.current_a
    twin.enable()
    twin.advance(0.05, 8000.0)
    ch = twin.advance((revolutions + 0.25) / (500 / 60 * 2), 8000.0,
                      channels=["time_s", "torque_nm", "rotor_angle_mech_rad"])
    stat = nonsynchronous_rms(ch["time_s"], ch["torque_nm"], 2 * ch["rotor_angle_mech_rad"],
                              max_order=48)
    return stat.rms_nm / PLAN_POINT.mean_torque_nm


@pytest.fixture(scope="module")
def floor_pu():
    """The twin's own non-synchronous floor at its default counter, its modelled share out."""
    model = predict_noise(PLAN_POINT, 2000, revolutions=8, max_order=48, **LOOP).rms_pu
    return math.sqrt(max(twin_noise_pu(2000, seed=7) ** 2 - model ** 2, 0.0))


@pytest.mark.parametrize("counts", [32, 64, 128])
def test_the_twin_lies_in_the_range_and_a_scaled_counter_does_not(counts, floor_pu):
    prediction = predict_noise(PLAN_POINT, counts, revolutions=8, max_order=48, **LOOP)
    low, high = prediction.expected_range_pu
    trials = prediction.trials_rms_pu
    assert (low, high) == pytest.approx((NOISE_RANGE_FACTORS[0] * min(trials),
                                         NOISE_RANGE_FACTORS[1] * max(trials)))

    def measured(applied):
        return math.sqrt(max(twin_noise_pu(applied) ** 2 - floor_pu ** 2, 0.0))

    assert low <= measured(counts) <= high
    for scale in (1.5, 0.7):           # hil.sim.defects: injection_scale, counts rounded
        assert not low <= measured(int(round(counts * scale))) <= high, scale
    # the additive white-noise form is low against the same drive (hil/model/README.md)
    assert prediction.white_noise_rms_pu < low


def test_bad_input_is_refused_with_the_allowed_values():
    with pytest.raises(InputError, match="0.5, 1, 1.5 or 2 periods"):
        computation_delay_periods(60e-6, 20_000.0)
    assert computation_delay_periods(75e-6, 20_000.0) == 1.0
    with pytest.raises(InputError, match="speed_rpm=0"):
        predict_noise(OperatingPoint(speed_rpm=0, current_a=20.0), 32, revolutions=8,
                      max_order=48, **LOOP)
    with pytest.raises(InputError, match="pwm_period_counts"):
        predict_noise(PLAN_POINT, 4, revolutions=8, max_order=48, **LOOP)
    limit_rpm = OperatingPoint(0, 40.0).voltage_limited_speed_rpm()
    with pytest.raises(InputError, match="sine linear range"):
        predict_noise(OperatingPoint(speed_rpm=0.95 * limit_rpm, current_a=40.0), 32,
                      revolutions=8, max_order=48, modulation="sine", **LOOP)


def test_reverse_rotation_is_braking_not_mirrored_motoring():
    """At a negative speed the drive still commands +I on q (positive torque): it brakes, and
    its steady references are V = −E + (R − j·|ω_e|·L)·I, not the motoring phasor. The simulated
    drive at −500 rpm, 30 A lies in the range of the model with the signed phasor (ratio ≈ 0.9
    at 32 counts); with the motoring phasor it read 0.64× (a correct drive rejected)."""
    op = OperatingPoint(speed_rpm=-500, current_a=30.0)
    motor = op.motor
    braking = -op.emf_peak_v + complex(motor.phase_resistance_ohm,
                                       -abs(op.elec_speed_rad_s) * motor.phase_inductance_h) * 30.0
    assert steady_phasor_peak_v(op) == pytest.approx(braking, abs=1e-12)
    assert steady_phasor_peak_v(PLAN_POINT) == PLAN_POINT.voltage_phasor_peak_v

    twin = DriveTwin(DriveConfig(), seed=1)
    twin.set_injection(pwm_period_counts=32)
    twin.speed_rpm, twin.current_command_a = op.speed_rpm, op.current_a
    twin.enable()
    twin.advance(0.05, 8000.0)
    ch = twin.advance(8.25 / (500 / 60 * 2), 8000.0,
                      channels=["time_s", "torque_nm", "rotor_angle_mech_rad"])
    stat = nonsynchronous_rms(ch["time_s"], ch["torque_nm"], 2 * ch["rotor_angle_mech_rad"],
                              max_order=48)
    prediction = predict_noise(op, 32, revolutions=stat.revolutions, max_order=48, **LOOP)
    low, high = prediction.expected_range_pu
    assert low <= stat.rms_nm / op.mean_torque_nm <= high


def test_a_drive_is_one_of_the_trials_not_their_mean():
    """8-pole 48 V motor (the validity study's p8_48v) at −250 rpm, 10 A, C = 32: few count
    boundaries are crossed, the trials (where the references sit within a count) spread
    0.46-0.90 %, and the correct drive (0.87 %) lay at 1.44× their quadratic mean, beyond the old
    [0.75, 1.25]× of it (a wrong rejection in studies/results/validity.md). It lies inside the
    range over the trials; a counter applied 1.5× at the same motor's C = 128 still falls
    outside."""
    from hil.motor import MotorParameters
    from hil.sim import MotorModel

    motor = MotorParameters(pole_count=8, dc_bus_v=48.0, phase_resistance_ohm=0.12,
                            phase_inductance_h=0.3e-3, max_reactance_ohm=0.4,
                            ke_v_s_per_rad=0.06, ke_definition="rms_phase")
    op = OperatingPoint(speed_rpm=-250.0, current_a=10.0, motor=motor)
    f_e = 250.0 / 60.0 * motor.pole_pairs

    def twin_pu(counts, seed=1):
        twin = DriveTwin(DriveConfig(motor=MotorModel(parameters=motor)), seed=seed)
        twin.set_injection(pwm_period_counts=counts)
        twin.speed_rpm, twin.current_command_a = op.speed_rpm, op.current_a
        twin.enable()
        twin.advance(0.05, 8000.0)
        ch = twin.advance(8.25 / f_e, 8000.0,
                          channels=["time_s", "torque_nm", "rotor_angle_mech_rad"])
        stat = nonsynchronous_rms(ch["time_s"], ch["torque_nm"],
                                  motor.pole_pairs * ch["rotor_angle_mech_rad"], max_order=48)
        return stat.rms_nm / op.mean_torque_nm

    floor = math.sqrt(max(twin_pu(2000, seed=7) ** 2 - predict_noise(
        op, 2000, revolutions=8, max_order=48, **LOOP).rms_pu ** 2, 0.0))

    def measured(counts):
        return math.sqrt(max(twin_pu(counts) ** 2 - floor ** 2, 0.0))

    coarse = predict_noise(op, 32, revolutions=8, max_order=48, **LOOP)
    value = measured(32)
    assert value > NOISE_RANGE_FACTORS[1] * coarse.rms_pu * 1.1       # beyond a range on the mean
    low, high = coarse.expected_range_pu
    assert low <= value <= high
    fine = predict_noise(op, 128, revolutions=8, max_order=48, **LOOP)
    low, high = fine.expected_range_pu
    assert low <= measured(128) <= high
    # a counter applied 1.5× (noise ≈ 0.67×) still falls below; 0.7× (≈ 1.4×) does not leave
    # this point's range (its trials spread ±22 % even at C = 128): the default point catches it
    assert measured(192) < low
