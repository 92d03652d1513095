"""PWM switching off the default point (issue 21 items 1-2): reverse rotation is braking, and the
DAQ rate is derived from the speed and the PWM frequency (never fixed for 500 rpm)."""

import math

import numpy as np
import pytest

from hil.analysis.switching import (MIN_EFFECTIVE_SAMPLES_PER_PERIOD, capture_settings,
                                    window_periods)
from hil.model import OperatingPoint, predict
from hil.motor import MotorParameters
from hil.sim import DriveConfig, MotorModel, simulate

DAQ = {"max_sample_rate_hz": 200_000.0, "buffer_samples": 200_000, "max_order": 24}


def twin_within_period_pk_pk_pu(speed_rpm, current_a, motor=None, pwm_hz=20_000.0):
    """Largest within-PWM-period pk-pk of the twin's air-gap torque, per unit of its mean
    (sampled at 50 points per period over one electrical revolution after settling)."""
    motor = motor or MotorParameters()
    per_period = 50
    elec_hz = abs(speed_rpm) * motor.pole_pairs / 60.0
    periods = int(round(pwm_hz / elec_hz))
    config = DriveConfig(current_command_a=current_a, speed_rpm=speed_rpm,
                         motor=MotorModel(parameters=motor))
    result = simulate(config, periods / pwm_hz, pwm_hz * per_period, settle_s=0.03,
                      channels=["time_s", "torque_em_nm"])
    torque = result.channels["torque_em_nm"][:periods * per_period]
    return float(np.max(np.ptp(torque.reshape(periods, per_period), axis=1)) / abs(torque.mean()))


def test_reverse_rotation_is_braking_not_mirrored_motoring():
    """At -800 rpm, 15 A the twin's switching ripple is the braking form's (within 10 %); the
    mirrored-motoring form (what the model gave before: the +800 rpm value) is 30 % off."""
    braking = predict("pwm_switching", OperatingPoint(-800.0, 15.0), pwm_frequency_hz=20_000.0,
                      model="switched_torque").pk_pk_pu
    mirrored = predict("pwm_switching", OperatingPoint(800.0, 15.0), pwm_frequency_hz=20_000.0,
                       model="switched_torque").pk_pk_pu
    twin = twin_within_period_pk_pk_pu(-800.0, 15.0)
    assert twin / braking == pytest.approx(1.0, abs=0.1)
    assert twin / mirrored < 0.8


def test_braking_on_another_motor_and_forward_unchanged():
    """A 2-pole 24 V motor with a low L/R, reverse: the braking form holds there too; forward
    rotation is the motoring form as before."""
    motor = MotorParameters(pole_count=2, dc_bus_v=24.0, phase_resistance_ohm=0.2,
                            phase_inductance_h=60e-6, max_reactance_ohm=0.019,
                            ke_v_s_per_rad=0.03)
    reverse = predict("pwm_switching", OperatingPoint(-700.0, 10.0, motor=motor),
                      pwm_frequency_hz=20_000.0, model="switched_torque").pk_pk_pu
    assert twin_within_period_pk_pk_pu(-700.0, 10.0, motor) / reverse == pytest.approx(
        1.0, abs=0.1)
    forward = OperatingPoint(700.0, 10.0, motor=motor)
    from hil.model.pwm_switching import forward_voltage_rms
    assert forward_voltage_rms(forward) == pytest.approx(forward.voltage_phasor_peak_v
                                                         / math.sqrt(2.0))


@pytest.mark.parametrize("speed_rpm,pole_pairs,pwm_hz", [
    (500.0, 2, 20_000.0), (-800.0, 2, 40_000.0), (1500.0, 2, 40_000.0), (1500.0, 2, 10_000.0),
    (100.0, 2, 10_000.0), (30.0, 2, 40_000.0), (-900.0, 4, 10_000.0), (1200.0, 1, 20_000.0)])
def test_capture_settings_fit_the_daq_and_walk_the_period(speed_rpm, pole_pairs, pwm_hz):
    """Derived from speed and PWM frequency: within the DAQ's rate and buffer, whole Hz, never an
    integer multiple of f_pwm, at least 8 effective samples per period (the 1500 rpm, 40 kHz
    point errored with the fixed 500 rpm rate: 5.4 effective samples)."""
    settings = capture_settings(speed_rpm, pole_pairs, pwm_hz, **DAQ)
    assert not isinstance(settings, str), settings
    elec_hz = abs(speed_rpm) * pole_pairs / 60.0
    assert settings.sample_rate_hz <= DAQ["max_sample_rate_hz"]
    assert settings.sample_rate_hz == int(settings.sample_rate_hz)
    assert (settings.revolutions + 0.25) / elec_hz * settings.sample_rate_hz \
        <= DAQ["buffer_samples"]
    assert 4 <= settings.revolutions <= 8
    assert settings.sample_rate_hz / pwm_hz != int(settings.sample_rate_hz / pwm_hz)
    assert settings.effective_samples_per_period >= MIN_EFFECTIVE_SAMPLES_PER_PERIOD
    assert settings.window_periods == window_periods(2 * math.pi * elec_hz, pwm_hz)


def test_a_point_the_daq_cannot_capture_gets_a_reason():
    """40 kHz on a 10-pole motor at 3000 rpm (and 8 poles at 3000 rpm): windows of one period,
    5 samples per period at most, the walk cannot help; 20 kHz at 3000 rpm on 20 poles: too few
    windows per revolution for order 24; the reason names it."""
    for args in ((3000.0, 5, 40_000.0), (3000.0, 4, 40_000.0)):
        reason = capture_settings(*args, **DAQ)
        assert isinstance(reason, str) and "effective samples per PWM period" in reason
    reason = capture_settings(3000.0, 10, 20_000.0, **DAQ)
    assert isinstance(reason, str) and "windows per electrical revolution" in reason
    reason = capture_settings(2.0, 2, 20_000.0, **DAQ)     # 8 revolutions would be 120 s
    assert isinstance(reason, str) and "buffer" in reason


def test_the_promised_effective_samples_are_those_of_the_whole_capture():
    """8-pole motor at 1500 rpm, 20 kHz (windows of one PWM period): the first 8 windows of
    199.5 kHz promised 9.97 effective samples per period, but every 40th window holds 9 samples
    and the analysis found 5.05 (a wrong rejection of the correct drive). The rate kept now
    promises what the analysis finds on the capture's time stamps, all windows counted."""
    from hil.analysis.switching import _windows, effective_samples_per_period
    from hil.analysis.angle import travel_angle

    assert effective_samples_per_period(199_500.0, 20_000.0, 1, windows=8) > 9.9
    assert effective_samples_per_period(199_500.0, 20_000.0, 1, windows=40) < 5.1
    for speed_rpm, pole_pairs, pwm_hz in ((1500.0, 4, 20_000.0), (2475.0, 4, 20_000.0),
                                          (1500.0, 2, 10_000.0), (-800.0, 4, 10_000.0),
                                          (500.0, 4, 40_000.0)):
        settings = capture_settings(speed_rpm, pole_pairs, pwm_hz, **DAQ)
        assert not isinstance(settings, str), settings
        elec_hz = abs(speed_rpm) * pole_pairs / 60.0
        rate = settings.sample_rate_hz
        time_s = np.arange(int((settings.revolutions + 0.25) / elec_hz * rate)) / rate
        travel = travel_angle(time_s, 2.0 * math.pi * elec_hz * time_s)
        found = _windows(time_s, travel, pwm_hz).effective_samples_per_period
        assert found == pytest.approx(settings.effective_samples_per_period, rel=1e-6)
        assert found >= MIN_EFFECTIVE_SAMPLES_PER_PERIOD


def test_no_rate_whose_sample_grid_is_synchronous_with_the_rotor():
    """8-pole motor at 1000 rpm, 20 kHz (windows of 2 periods, 150 per revolution): 190 kHz put
    the same 19 phases in every window; the corners they miss move with the duty cycles, and
    the correct drive's envelope read orders 3, 6, 9 (order 6 at 1/7 of its amplitude at
    10 kHz): a wrong rejection on the signature. Such rates, and rates whose arrangement cycle
    fits a whole number of times in a revolution (500 rpm: 195 kHz repeats every 4 windows of
    5 periods, 120 per revolution), are not chosen; nor are rates that are so only nearly,
    rounded to whole Hz, or whose window phase grid beats a whole number of times per
    revolution. 10-pole motor at 1200 rpm, 40 kHz, windows of 3 periods: 186667 Hz (14/3·40 kHz
    + ⅓ Hz) had been kept and the correct drive's envelope lost its order 6 (3e-5 N·m where
    1e-3 was due, "dominant order 2": a wrong rejection); 187 kHz beats at 1 kHz = 10·f_e (the
    12-pole motor at 1000 rpm read "dominant order 10" there); 187027 Hz reads order 6 at
    0.95e-3 N·m (hil run on that bench)."""
    from hil.analysis.switching import synchronous_grid

    per_revolution = 40_000.0 / 100.0 / 3
    assert synchronous_grid(190_000.0, 20_000.0, 2, 150.0)
    assert synchronous_grid(195_000.0, 20_000.0, 5, 120.0)
    assert synchronous_grid(193_333.0, 20_000.0, 3, 125.0)
    assert synchronous_grid(186_667.0, 40_000.0, 3, per_revolution)
    assert synchronous_grid(187_000.0, 40_000.0, 3, per_revolution)
    assert not synchronous_grid(193_514.0, 20_000.0, 3, 125.0)
    assert not synchronous_grid(187_027.0, 40_000.0, 3, per_revolution)
    for speed_rpm, pole_pairs, pwm_hz in ((1000.0, 4, 20_000.0), (500.0, 4, 20_000.0),
                                          (1200.0, 4, 40_000.0), (-500.0, 2, 10_000.0),
                                          (1200.0, 5, 40_000.0), (1000.0, 6, 40_000.0),
                                          (1538.0, 2, 20_000.0)):
        settings = capture_settings(speed_rpm, pole_pairs, pwm_hz, **DAQ)
        elec_hz = abs(speed_rpm) * pole_pairs / 60.0
        per_revolution = pwm_hz / (elec_hz * settings.window_periods)
        assert not synchronous_grid(settings.sample_rate_hz, pwm_hz, settings.window_periods,
                                    per_revolution)
        assert settings.effective_samples_per_period >= MIN_EFFECTIVE_SAMPLES_PER_PERIOD


def test_a_point_whose_active_states_the_daq_cannot_sample_is_refused_with_the_reason():
    """Braking at -500 rpm / 20 A the 14-pole 48 V motor's drive needs M = 0.046: at 10 kHz the
    active states last ≈ 7.9 µs of the 100 µs period and the DAQ's phases are ≈ 5.4 µs apart:
    1.5 phases on them, too few to find the extremes (the plan read 0.41 of the twin's ripple,
    studies/switching_sampling.py): refused, not judged. Motoring at +500 rpm it is judged, and
    so is Table I's default point at every PWM frequency of the sweep."""
    import dataclasses

    from hil.config import default_sim_bench
    from ripple_hil_testplans.conditions import PWM_SWITCHING_SWEEP
    from ripple_hil_testplans.test_pwm_switching import (MIN_ACTIVE_SAMPLES,
                                                         active_state_problem, capture)

    def config_at(speed_rpm, current_a, motor=None):
        base = default_sim_bench()
        return dataclasses.replace(
            base, motor=motor or base.motor,
            operating_point=dataclasses.replace(base.operating_point, speed_rpm=speed_rpm,
                                                current_a=current_a))

    p14 = MotorParameters(pole_count=14, dc_bus_v=48.0, phase_resistance_ohm=0.1,
                          phase_inductance_h=0.3e-3, max_reactance_ohm=0.5,
                          ke_v_s_per_rad=0.04, ke_definition="peak_phase")
    injection = {"pwm_frequency_hz": 10_000.0}
    braking = config_at(-500.0, 20.0, p14)
    reason = active_state_problem(braking, injection, capture(braking, injection))
    assert reason is not None and f"fewer than {MIN_ACTIVE_SAMPLES:g}" in reason
    assert "modulation index 0.04" in reason
    motoring = config_at(500.0, 20.0, p14)
    assert active_state_problem(motoring, injection, capture(motoring, injection)) is None
    default = default_sim_bench()
    for sweep in PWM_SWITCHING_SWEEP:
        assert active_state_problem(default, sweep, capture(default, sweep)) is None


def test_below_the_limit_only_a_low_reading_is_not_determinable():
    """The sampling can only miss extremes, so only a reading below the prediction is excused;
    a reading above it (a drive at half the PWM frequency reads ≈ 1.9x) stays judged — also
    below the middle of a zone that the ADC dither bound lifts at the top only."""
    from types import SimpleNamespace

    from ripple_hil_testplans.test_pwm_switching import reads_low

    zone = {"lower_limit_pu": 0.008, "upper_limit_pu": 0.012, "predicted_pk_pk_pu": 0.010}
    assert reads_low(SimpleNamespace(measured_pk_pk_pu=0.004, **zone))
    assert reads_low(SimpleNamespace(measured_pk_pk_pu=0.0085, **zone))
    assert not reads_low(SimpleNamespace(measured_pk_pk_pu=0.019, **zone))
    assert not reads_low(SimpleNamespace(measured_pk_pk_pu=0.0105, **zone))
    lifted = zone | {"upper_limit_pu": 0.016}
    assert not reads_low(SimpleNamespace(measured_pk_pk_pu=0.0105, **lifted))
    assert not reads_low(None)


def test_a_reading_known_to_be_biased_is_not_a_slope_point():
    """A point excused as reading low where the DAQ cannot sample the active states is noted
    in the record and left out of the sweep's slope (it is biased, not just uncertain)."""
    from types import SimpleNamespace

    from ripple_hil_testplans.sensitivity import SWEEP_EXCLUDED_NOTE, sweep_points

    def entry(test_id, notes):
        return {"test_id": test_id, "source": "pwm_switching", "verdict": {"x": 1},
                "measured": {"x": 1}, "notes": notes}

    record = SimpleNamespace(tests=[entry("a", ["expectation"]),
                                    entry("b", ["expectation", SWEEP_EXCLUDED_NOTE + "low"]),
                                    entry("c", [])])
    assert [t["test_id"] for t in sweep_points(record, "pwm_switching")] == ["a", "c"]
