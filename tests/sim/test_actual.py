"""``[simulation.actual]``: the simulated bench's physics apart from what its file states
(issue 29 Build 1): parsing and recording, the twin built from it, and the saturation and
warming physics against an equivalent linear twin."""

import math

import numpy as np
import pytest

from hil.config import default_sim_bench, example_bench_path, load_bench
from hil.errors import InputError
from hil.sim import DriveConfig, FirmwareModel, MotorModel, simulate
from hil.sim import layout as L
from hil.sim.packing import pack_params
from hil.sim.twin import DriveTwin
from hil.simbench import twin_config

WARM_SATURATED = {"phase_resistance_ohm": 0.055 * 1.3, "phase_inductance_h": 38.5e-6 * 0.8,
                  "ke_v_s_per_rad": 0.023 * 0.96}


def test_table_is_validated_recorded_and_refused_on_a_real_bench():
    bench = default_sim_bench().with_overrides({"simulation": {"actual": WARM_SATURATED}})
    assert bench.sim_actual == WARM_SATURATED
    assert bench.to_dict()["simulation"] == {"actual": WARM_SATURATED}
    assert bench.motor == default_sim_bench().motor             # the file's nameplate stays
    for bad, match in [({"phase_resistance": 0.07}, "phase_resistance"),
                       ({"phase_inductance_h": -1.0}, "phase_inductance_h"),
                       ({"winding_time_constant_s": 10.0}, "go together"),
                       ({"current_loop_delay_s": 60e-6}, "current_loop_delay_s"),
                       ({"current_loop_bandwidth_hz": 5000.0}, "current_loop_bandwidth_hz")]:
        with pytest.raises(InputError, match=match):
            default_sim_bench().with_overrides({"simulation": {"actual": bad}})
    real = load_bench(example_bench_path("real-bench"))
    with pytest.raises(InputError, match="simulation.actual .* simulated = true"):
        real.with_overrides({"simulation": {"actual": WARM_SATURATED}})


def test_twin_runs_the_actual_plant_with_gains_from_the_nameplate():
    stated = default_sim_bench()
    actual = stated.with_overrides({"simulation": {"actual": WARM_SATURATED | {
        "current_loop_bandwidth_hz": 1200.0, "current_loop_delay_s": 50e-6,
        "bandwidth_hz": 700.0, "saturation_current_a": 40.0,
        "winding_time_constant_s": 5.0, "winding_rise_pu_per_a2": 1e-4}}})
    config = twin_config(actual)
    motor = config.motor.parameters
    assert (motor.phase_resistance_ohm, motor.phase_inductance_h, motor.ke_v_s_per_rad) == \
        tuple(WARM_SATURATED.values())
    assert (config.motor.saturation_current_a, config.motor.thermal_time_constant_s,
            config.motor.resistance_rise_pu_per_a2) == (40.0, 5.0, 1e-4)
    assert config.firmware.bandwidth_per_pwm == pytest.approx(0.06)
    assert config.firmware.delay_periods == 0.5 and config.transducer.bandwidth_hz == 700.0
    assert config.firmware.tuning == stated.motor
    # the firmware's gains are the nameplate's (Kp = L·ωc, Ki = R·ωc), the plant's R, L are not
    base, moved = pack_params(twin_config(stated)), pack_params(config)
    assert moved[L.P_KP_PU] == pytest.approx(base[L.P_KP_PU] * 0.06 / 0.08, rel=1e-3)
    assert moved[L.P_R] == pytest.approx(base[L.P_R] * 1.3)
    # no table: the twin is the file's (nothing moved)
    assert twin_config(stated).firmware.tuning is None


def _run(motor: MotorModel, channels=("ia_a", "ib_a", "va_v", "iq_a")):
    """The motor behind the same firmware (gains set for Table I's nameplate)."""
    firmware = FirmwareModel(tuning=MotorModel().parameters)
    return simulate(DriveConfig(motor=motor, firmware=firmware, current_command_a=20.0,
                                speed_rpm=500.0),
                    0.01, 100_000.0, settle_s=0.03, channels=channels).channels


def test_saturated_inductance_behaves_as_the_linear_one_at_that_current():
    """At |i| = i_sat/2 the saturated motor has L/(1 + 1/4) = 0.8·L: its PWM current ripple and
    its currents match a linear motor with 0.8·L (and not the unsaturated L)."""
    table_i = MotorModel().parameters
    saturated = _run(MotorModel(saturation_current_a=40.0))
    half = _run(MotorModel(parameters=_scaled(table_i, inductance=0.8)))
    full = _run(MotorModel())
    ripple = {name: np.std(np.diff(run["ia_a"])) for name, run in
              (("saturated", saturated), ("half", half), ("full", full))}
    assert ripple["saturated"] == pytest.approx(ripple["half"], rel=0.05)
    assert ripple["saturated"] > 1.15 * ripple["full"]
    assert np.max(np.abs(saturated["ia_a"] - half["ia_a"])) < 0.05 * 20.0


def test_winding_warms_with_its_copper_loss():
    """τ·dw/dt = k·|i|² − w: after the settle the rise is k·I²·(1 − e^(−t/τ)) (checked in the
    engine's state) and the phase voltage is that of a linear motor with R·(1 + w)."""
    k, tau = 0.3 / 20.0 ** 2, 0.01
    warm = MotorModel(thermal_time_constant_s=tau, resistance_rise_pu_per_a2=k)
    twin = DriveTwin(DriveConfig(motor=warm, current_command_a=20.0, speed_rpm=500.0))
    twin.advance(0.005, 20_000.0, channels=("time_s",))
    rise_5ms = twin._state[L.S_WARM]
    # the current needs ≈ 1 ms to reach 20 A: the rise lies between the two exponentials
    assert 0.3 * -math.expm1(-0.004 / tau) < rise_5ms < 0.3 * -math.expm1(-0.005 / tau)
    twin.advance(0.1, 20_000.0, channels=("time_s",))
    assert twin._state[L.S_WARM] == pytest.approx(0.3, rel=0.01)
    hot = _run(warm)
    linear = _run(MotorModel(parameters=_scaled(MotorModel().parameters, resistance=1.3)))
    assert np.mean(np.abs(hot["va_v"] - linear["va_v"])) < 0.01 * np.mean(np.abs(linear["va_v"]))
    cold = _run(MotorModel())
    assert np.mean(np.abs(hot["va_v"] - cold["va_v"])) > 0.05 * np.mean(np.abs(linear["va_v"]))


def _scaled(motor, *, resistance=1.0, inductance=1.0):
    from dataclasses import replace
    return replace(motor, phase_resistance_ohm=motor.phase_resistance_ohm * resistance,
                   phase_inductance_h=motor.phase_inductance_h * inductance)
