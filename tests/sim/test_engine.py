"""The engine's own physics and numerics: exactness, dead-time clamping, neutral, EMF harmonics,
cogging, torque consistency, transducer, determinism, batch and capture output."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hil.capture import Capture
from hil.motor import TABLE_I
from hil.sim import (DriveConfig, DriveTwin, DynoModel, Injection, InverterModel, MotorModel,
                     TransducerModel, layout, simulate, simulate_batch)
from hil.sim.electrical import (BASIS_COLUMNS, MAX_HARMONICS, evaluate, harmonic_table,
                                impedance_angles, period_basis)
from hil.sim.kernel import run_drive
from hil.sim.packing import new_state, pack_params
from hil.sim.results import select_channels
from sim_spectra import amplitude_at, dominant_order, run

#: the engine's row map for every channel (row c of ``out`` is channel c)
ALL_ROWS = select_channels(None)[1]


def test_forced_response_solves_the_phase_equation():
    # L·di_e/dt + R·i_e = −(e − mean e) for a motor with 5th and 9th (zero-sequence) harmonics
    config = DriveConfig(motor=MotorModel(emf_harmonics=((5, 0.03, 0.4), (9, 0.02, 0.0))))
    params = pack_params(config)
    orders, amplitudes, phases = (np.zeros(MAX_HARMONICS) for _ in range(3))
    count = harmonic_table(params, orders, amplitudes, phases)
    lag = np.zeros((MAX_HARMONICS, 3))
    basis = np.zeros((MAX_HARMONICS, BASIS_COLUMNS))
    omega_m = 1000 * 2 * math.pi / 60
    impedance_angles(params, omega_m, orders, amplitudes, count, lag)
    period_basis(params, 0.3, orders, amplitudes, phases, count, lag, basis)
    omega_e = 2 * omega_m
    step = 1e-8
    for tau in (0.0, 1e-5, 4e-5, 3e-3):
        before = np.array(evaluate(tau - step, omega_e, orders, count, basis))
        now = np.array(evaluate(tau, omega_e, orders, count, basis))
        after = np.array(evaluate(tau + step, omega_e, orders, count, basis))
        di_dt = (after[:3] - before[:3]) / (2 * step)
        emf = omega_m * now[3:]
        residual = TABLE_I.phase_inductance_h * di_dt + TABLE_I.phase_resistance_ohm * now[:3] \
            + (emf - emf.mean())
        assert np.abs(residual).max() < 1e-6 * np.abs(emf).max()


def test_sample_rate_does_not_change_the_trajectory():
    # switching instants come from the counter, not from a step grid: sampling 25x denser
    # yields the same values at the common instants
    config = DriveConfig(injection=Injection(dead_time_s=1e-6), speed_rpm=600.0)
    coarse = simulate(config, 0.004, 40_000)
    fine = simulate(config, 0.004, 1_000_000)
    for name in ("ia_a", "ib_a", "torque_em_nm"):
        np.testing.assert_allclose(fine[name][::25], coarse[name], atol=1e-9)


@pytest.mark.parametrize("current_a, dead_time_s", [(10.0, 1e-6), (1.0, 5e-6)])
def test_merging_dead_intervals_does_not_change_the_solution(current_a, dead_time_s):
    # the engine skips a dead-interval boundary when the dead leg's current provably keeps its
    # sign; the exact solution must not notice (only the transducer's piecewise-linear input
    # moves, by < 1e-4 N·m)
    config = DriveConfig(injection=Injection(dead_time_s=dead_time_s), speed_rpm=900.0,
                         current_command_a=current_a)
    outs = []
    for merge in (1.0, 0.0):
        params = pack_params(config)
        params[layout.P_MERGE_SEGMENTS] = merge
        out = np.zeros((layout.N_CHANNELS, 2000))
        run_drive(params, new_state(), 0.0, 1e-5, out, ALL_ROWS, np.zeros(layout.N_CHANNELS),
                  0.02)
        outs.append(out)
    for row in (layout.C_IA, layout.C_IB, layout.C_TORQUE_EM, layout.C_VA):
        np.testing.assert_allclose(outs[0][row], outs[1][row], atol=1e-9)
    np.testing.assert_allclose(outs[0][layout.C_TORQUE_SHAFT_FILTERED],
                               outs[1][layout.C_TORQUE_SHAFT_FILTERED], atol=1e-4)


def test_period_volt_seconds_balance_the_current_change():
    # per PWM period: L·Δi = ∫v_an dt − R·∫i dt − ∫e dt, with ∫v_an from the inverter model's
    # own bookkeeping (va_v) and the integrals of i and e from 1 MHz samples of the solution
    result = simulate(DriveConfig(speed_rpm=600.0, current_command_a=20.0), 0.002, 1_000_000,
                      settle_s=0.01)
    per = 50
    ia = result["ia_a"]
    theta_e = 2 * result["rotor_angle_mech_rad"]
    emf = TABLE_I.emf_peak_v_s_per_rad * 600 * 2 * math.pi / 60 * np.sin(theta_e)
    dt = 1e-6
    for start in range(0, len(ia) - per - 1, per * 7):
        window = slice(start, start + per + 1)
        integral_i = np.trapezoid(ia[window], dx=dt)
        integral_e = np.trapezoid(emf[window], dx=dt)
        volt_seconds = result["va_v"][start] * per * dt
        lhs = TABLE_I.phase_inductance_h * (ia[start + per] - ia[start])
        rhs = volt_seconds - TABLE_I.phase_resistance_ohm * integral_i - integral_e
        assert lhs == pytest.approx(rhs, abs=2e-3 * abs(volt_seconds) + 1e-8)


def test_dead_time_clamps_a_phase_at_zero_current():
    # low current, long dead time: during a dead interval the diodes block at zero current
    config = DriveConfig(injection=Injection(dead_time_s=5e-6), current_command_a=1.0,
                         speed_rpm=300.0)
    result = simulate(config, 0.02, 2_000_000, settle_s=0.01)
    currents = np.stack([result["ia_a"], result["ib_a"], result["ic_a"]])
    held = (currents == 0.0) & np.roll(currents == 0.0, 1, axis=1)
    assert held.sum() > 100
    np.testing.assert_allclose(currents.sum(axis=0), 0.0, atol=1e-9)
    phase, index = np.nonzero(held)
    others = [k for k in range(3) if k != phase[0]]
    assert currents[others[0], index[0]] == pytest.approx(-currents[others[1], index[0]])


def test_isolated_neutral_has_no_zero_sequence_current_connected_has():
    isolated = run(revs=2)
    connected = run(revs=2, config=DriveConfig(motor=MotorModel(neutral_connected=True),
                                               current_command_a=10.0, speed_rpm=300.0))
    zero_seq = lambda r: r["ia_a"] + r["ib_a"] + r["ic_a"]  # noqa: E731
    assert np.abs(zero_seq(isolated)).max() < 1e-9
    # SVPWM's min-max zero sequence (a triangle at 3× the fundamental) drives neutral current
    assert np.abs(zero_seq(connected)).max() > 0.5
    assert dominant_order(zero_seq(connected) + 1.0, 2) == 3.0


@pytest.mark.parametrize("order", [5, 7])
def test_emf_harmonic_gives_order_six_of_its_size(order):
    # sinusoidal currents in a 5th or 7th EMF harmonic of r per unit: Σ e·i has an order-6 term
    # of amplitude r per unit of the mean (φ = 0). 5 %: the loop lets a little harmonic current
    # through at 300 rpm (the harmonic EMF's current adds its own order-6 term).
    motor = MotorModel(emf_harmonics=((order, 0.02, 0.0),))
    result = run(config=DriveConfig(motor=motor, current_command_a=10.0, speed_rpm=300.0))
    assert dominant_order(result["torque_em_nm"], 4) == 6.0
    assert amplitude_at(result["torque_em_nm"], 4, 6) == pytest.approx(0.02, rel=0.05)


def test_cogging_adds_to_shaft_torque_only():
    motor = MotorModel(cogging=((24, 0.01, 0.3),))
    result = run(revs=2, config=DriveConfig(motor=motor, current_command_a=10.0,
                                            speed_rpm=300.0))
    expected = 0.01 * np.sin(24 * result["rotor_angle_mech_rad"] + 0.3)
    np.testing.assert_allclose(result["torque_shaft_nm"] - result["torque_em_nm"], expected,
                               atol=1e-12)


@pytest.mark.parametrize("speed_rpm", [0.0, 300.0, -900.0])
def test_torque_sum_equals_dq_torque(speed_rpm):
    # sinusoidal EMF: Σ e_x·i_x/ω_m = (3/2)·sqrt(2)·Ke·i_q exactly, also at standstill
    result = simulate(DriveConfig(speed_rpm=speed_rpm, current_command_a=20.0), 0.01, 100_000)
    expected = TABLE_I.torque_constant_nm_per_a * result["iq_a"]
    np.testing.assert_allclose(result["torque_em_nm"], expected, atol=1e-12)
    assert result["speed_rpm"][0] == speed_rpm


def test_transducer_filters_gain_and_noise():
    quiet = TransducerModel(noise_rms_nm=0.0, accuracy_class_pct=0.0, bandwidth_hz=1000.0)
    result = run(config=DriveConfig(transducer=quiet, current_command_a=10.0, speed_rpm=300.0),
                 sample_rate_hz=200_000, revs=2)
    measured, shaft = result["torque_nm"], result["torque_shaft_nm"]
    assert measured.mean() == pytest.approx(shaft.mean(), rel=1e-3)
    # the PWM-frequency torque ripple is attenuated by the 1 kHz first-order filter
    assert np.std(measured) < 0.2 * np.std(shaft)
    noisy = TransducerModel(noise_rms_nm=1e-3, accuracy_class_pct=0.5)
    a = run(config=DriveConfig(transducer=noisy), revs=2)
    b = run(config=DriveConfig(transducer=noisy), revs=2)
    gain = a.meta["transducer_gain_error_pu"]
    assert 0 < abs(gain) <= 0.005
    np.testing.assert_array_equal(a["torque_nm"], b["torque_nm"])
    residual = a["torque_nm"] - (1 + gain) * simulate(
        DriveConfig(transducer=TransducerModel(noise_rms_nm=0.0, accuracy_class_pct=0.0)),
        len(a) / 20_000, 20_000, settle_s=0.05)["torque_nm"]
    assert np.std(residual) == pytest.approx(1e-3, rel=0.15)


def test_seed_changes_only_the_transducer():
    one = simulate(DriveConfig(), 0.01, 20_000, seed=1)
    two = simulate(DriveConfig(), 0.01, 20_000, seed=2)
    np.testing.assert_array_equal(one["torque_em_nm"], two["torque_em_nm"])
    assert not np.array_equal(one["torque_nm"], two["torque_nm"])


def test_batch_matches_single_runs():
    configs = [DriveConfig(injection=Injection(ia_offset_a=0.1 * k)) for k in range(4)]
    batch = simulate_batch(configs, 0.01, 20_000, seed=7)
    for config, result in zip(configs, batch):
        single = simulate_batch([config], 0.01, 20_000, seed=7, parallel=False)[0]
        np.testing.assert_array_equal(result["torque_em_nm"], single["torque_em_nm"])
    assert not np.array_equal(batch[0]["torque_em_nm"], batch[3]["torque_em_nm"])


def test_stepping_dyno_moves_by_steps_and_dwells():
    # dwell 2 ms, then move 10 counts at 60 rpm, repeat; the engine holds the speed constant
    # within a PWM period, so the angle follows the profile to within one period of motion
    step = 2 * math.pi / 7200 * 10
    speed = 2 * math.pi                                     # 60 rpm in rad/s
    dyno = DynoModel(mode="stepping", step_mech_rad=step, dwell_s=0.002)
    result = simulate(DriveConfig(dyno=dyno, speed_rpm=60.0), 0.02, 100_000)
    time, angle = result["time_s"], result["rotor_angle_mech_rad"]
    cycle = 0.002 + step / speed
    done = np.floor(time / cycle)
    profile = done * step + np.clip((time - done * cycle - 0.002) * speed, 0.0, step)
    assert np.abs(angle - profile).max() <= speed / 20_000 + 1e-12
    assert np.all(np.diff(angle) >= 0)
    assert (np.diff(angle) == 0).sum() > 0.4 * len(angle)


def test_ramp_dyno_slews_to_the_setpoint():
    config = DriveConfig(dyno=DynoModel(mode="ramp", ramp_rpm_per_s=10_000.0), speed_rpm=300.0)
    twin = DriveTwin(config)
    twin.advance(0.01, 10_000)
    twin.speed_rpm = 800.0
    speeds = twin.advance(0.1, 1_000)["speed_rpm"]
    assert speeds[0] < 500.0
    assert speeds[-1] == pytest.approx(800.0)
    assert np.all(np.diff(speeds) <= 10_000.0 / 1_000 + 1e-6)


def test_result_becomes_a_capture(tmp_path):
    result = simulate(DriveConfig(), 0.005, 10_000)
    capture = result.to_capture()
    digest = capture.save(tmp_path / "sim.npz")
    loaded = Capture.load(tmp_path / "sim.npz")
    assert len(digest) == 64
    assert loaded.meta["pole_pairs"] == 2 and loaded.meta["encoder_counts_per_rev"] == 7200
    assert loaded.meta["source"] == "simulation"
    for name in ("time_s", "rotor_angle_mech_rad", "encoder_counts", "ia_a", "ib_a", "ic_a",
                 "torque_nm", "torque_em_nm", "dc_bus_v", "speed_rpm", "id_a", "iq_a", "va_v"):
        np.testing.assert_array_equal(loaded[name], result[name])
    assert loaded.units["torque_nm"] == "N*m"


def test_sine_modulation_runs_within_its_smaller_linear_range():
    result = run(revs=2, config=DriveConfig(inverter=InverterModel(modulation="sine"),
                                            current_command_a=10.0, speed_rpm=300.0))
    assert result["iq_a"].mean() == pytest.approx(10.0, rel=0.01)


def test_one_period_matches_an_independent_ode_solution():
    # one PWM period with known latched compare values, integrated independently with scipy
    # (gate timing from the up/down counter, diode voltages in the dead intervals, isolated
    # neutral, sinusoidal EMF): the engine's exact solution must agree to 1e-6 A
    from scipy.integrate import solve_ivp
    dead, top, period = 2e-6, 2000.0, 50e-6
    omega = 600 * 2 * math.pi / 60
    params = pack_params(DriveConfig(speed_rpm=600.0, enabled=False,
                                     injection=Injection(dead_time_s=dead)))
    state = new_state()
    state[layout.S_INITIALISED] = 1.0
    state[layout.S_OMEGA_M] = omega
    state[layout.S_THETA_M] = 0.3
    state[layout.S_IA:layout.S_IC + 1] = (8.0, -3.0, -5.0)
    compares = (1500.0, 700.0, 300.0)
    state[layout.S_CMP_A:layout.S_CMP_C + 1] = compares
    out = np.zeros((layout.N_CHANNELS, 500))
    run_drive(params, state, 0.0, period / 500, out, ALL_ROWS, np.zeros(layout.N_CHANNELS),
              period)

    t_on = [(top - c) / top * period / 2 for c in compares]
    signs = np.sign([8.0, -3.0, -5.0])          # currents keep their sign over this period
    psi, r, ind = TABLE_I.emf_peak_v_s_per_rad, TABLE_I.phase_resistance_ohm, \
        TABLE_I.phase_inductance_h

    def leg_voltage(x, t):
        on, off = t_on[x], period - t_on[x]
        if on + dead <= t < off:
            return 12.0
        if on <= t < on + dead or off <= t < off + dead:
            return 0.0 if signs[x] > 0 else 12.0
        return 0.0

    def rhs(t, i, v):
        theta = 2 * (0.3 + omega * t)
        e = psi * omega * np.sin(theta - np.arange(3) * 2 * math.pi / 3)
        neutral = (v.sum() - e.sum()) / 3
        return (v - neutral - r * i - e) / ind

    edges = sorted({0.0, period} | {t for x in range(3) for t in
                                    (t_on[x], t_on[x] + dead, period - t_on[x],
                                     period - t_on[x] + dead) if t < period})
    times = out[layout.C_TIME]
    current = np.array([8.0, -3.0, -5.0])
    expected = np.zeros((3, len(times)))
    for start, end in zip(edges[:-1], edges[1:]):
        inside = (times >= start) & (times < end)
        volts = np.array([leg_voltage(x, 0.5 * (start + end)) for x in range(3)])
        solution = solve_ivp(rhs, (start, end), current, method="DOP853", rtol=1e-11,
                             atol=1e-12, t_eval=np.append(times[inside], end), args=(volts,))
        expected[:, inside] = solution.y[:, :-1]
        current = solution.y[:, -1]
    simulated = np.stack([out[layout.C_IA], out[layout.C_IB], out[layout.C_IC]])
    np.testing.assert_allclose(simulated, expected, atol=1e-6)
    assert np.ptp(simulated[0]) > 1.0                 # the period does switch amperes
