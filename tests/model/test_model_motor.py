"""Ke's definition (issue 13 item 6): one conversion in hil.motor, stated in the bench file, and
operating points beyond the voltage limit refused."""

import math
import tomllib

import pytest

from hil.config import BenchConfig, default_sim_bench, example_bench_path
from hil.errors import InputError
from hil.model import OperatingPoint, predict
from hil.motor import KE_DEFINITIONS, TABLE_I, MotorParameters


@pytest.mark.parametrize("definition,peak_per_ke", [
    ("rms_phase", math.sqrt(2)), ("peak_phase", 1.0), ("rms_line", math.sqrt(2 / 3)),
    ("peak_line", 1 / math.sqrt(3))])
def test_every_definition_gives_the_peak_phase_emf(definition, peak_per_ke):
    motor = MotorParameters(ke_v_s_per_rad=0.023, ke_definition=definition)
    assert motor.emf_peak_v_s_per_rad == pytest.approx(0.023 * peak_per_ke)
    assert motor.flux_linkage_wb == pytest.approx(0.023 * peak_per_ke / 2)
    assert motor.torque_constant_nm_per_a == pytest.approx(1.5 * 0.023 * peak_per_ke)
    assert motor.emf_rms_v_s_per_rad == pytest.approx(0.023 * peak_per_ke / math.sqrt(2))


def test_line_to_line_rms_is_the_phase_rms_times_root_3():
    phase = MotorParameters(ke_v_s_per_rad=0.023, ke_definition="rms_phase")
    line = MotorParameters(ke_v_s_per_rad=0.023 * math.sqrt(3), ke_definition="rms_line")
    assert line.emf_peak_v_s_per_rad == pytest.approx(phase.emf_peak_v_s_per_rad)


def test_unknown_definition_is_refused():
    with pytest.raises(ValueError, match="ke_definition must be one of"):
        MotorParameters(ke_definition="rms")


def test_bench_file_states_the_definition_and_predictions_follow_it():
    base = tomllib.loads(example_bench_path("sim-bench").read_text())
    assert base["motor"]["ke_definition"] == TABLE_I.ke_definition
    assert default_sim_bench().motor.ke_definition == TABLE_I.ke_definition
    base["motor"]["ke_definition"] = "peak_phase"
    bench = BenchConfig.from_dict(base)
    assert bench.motor.emf_peak_v_s_per_rad == pytest.approx(0.023)
    base["motor"]["ke_definition"] = "rms_phase"
    op_rms = OperatingPoint(1000, 20.0, motor=BenchConfig.from_dict(base).motor)
    op_peak = OperatingPoint(1000, 20.0, motor=bench.motor)
    assert op_peak.mean_torque_nm == pytest.approx(op_rms.mean_torque_nm / math.sqrt(2))
    # a voltage-dependent prediction moves with the reading (PWM switching: M = V_pk/V_dc)
    assert predict("pwm_switching", op_peak).pk_pk_pu != pytest.approx(
        predict("pwm_switching", op_rms).pk_pk_pu, rel=0.05)
    base["motor"]["ke_definition"] = "rms"
    with pytest.raises(InputError, match="motor.ke_definition"):
        BenchConfig.from_dict(base)


@pytest.mark.parametrize("definition", ["rms_phase", "peak_phase", "rms_line"])  # < 3000 rpm
def test_points_beyond_the_voltage_limit_are_refused_with_the_speed_allowed(definition):
    motor = MotorParameters(ke_definition=definition)
    limit_rpm = OperatingPoint(0, 20.0, motor=motor).voltage_limited_speed_rpm()
    edge = OperatingPoint(limit_rpm * 0.999, 20.0, motor=motor)
    assert abs(edge.voltage_phasor_peak_v) <= 12 / math.sqrt(3)
    assert abs(edge.voltage_phasor_peak_v) > 0.99 * 12 / math.sqrt(3)
    with pytest.raises(InputError, match=r"V_dc/√3.*allowed: \|speed_rpm\| <= "):
        OperatingPoint(limit_rpm * 1.01, 20.0, motor=motor)
    beyond = OperatingPoint(limit_rpm * 1.01, 20.0, motor=motor, allow_beyond_voltage_limit=True)
    assert beyond.speed_rpm > limit_rpm


def test_the_rms_phase_reading_stops_short_of_table_i_top_speed():
    """The evidence of hil/model/README.md: peak-phase puts the no-load voltage limit at the
    2790 rpm of X_s = 22.5 mΩ, RMS-phase ~30 % below it."""
    rms, peak = (OperatingPoint(0, 1e-6, motor=MotorParameters(ke_definition=d))
                 .voltage_limited_speed_rpm() for d in ("rms_phase", "peak_phase"))
    assert TABLE_I.max_speed_rpm == pytest.approx(2790, abs=5)
    assert rms < 0.75 * TABLE_I.max_speed_rpm
    assert peak == pytest.approx(TABLE_I.max_speed_rpm, rel=0.04)
    assert set(KE_DEFINITIONS) == {"rms_phase", "peak_phase", "rms_line", "peak_line"}
