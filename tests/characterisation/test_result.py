"""The bench as measured (``Characterisation.measured_config``): the plans' models see the
measured motor as the plant and the stated nameplate as the motor the drive's PI gains were
designed from (the drive was configured from it; issue 29)."""

from dataclasses import replace

import pytest

from hil.characterisation.identify import Identified
from hil.characterisation.result import Characterisation
from hil.config import default_sim_bench


def _identified(name: str, value: float, u: float) -> Identified:
    return Identified(name, value, u, "SI", "test")


def test_a_motor_measured_off_its_nameplate_keeps_the_nameplate_as_the_loop_tuning():
    stated = default_sim_bench()
    warm_r = stated.motor.phase_resistance_ohm * 1.3
    result = Characterisation(identified=(_identified("phase_resistance_ohm", warm_r, 1e-4),))
    measured = result.measured_config(stated)
    assert measured.motor.phase_resistance_ohm == warm_r
    assert measured.loop_tuning == stated.motor
    point = measured.model_point(500.0, 20.0)
    assert point.motor == measured.motor and point.loop_motor == stated.motor
    recorded = result.to_dict(stated)["loop_tuning"]      # the record says what the models used
    assert recorded["phase_resistance_ohm"] == stated.motor.phase_resistance_ohm


def test_a_motor_the_measurement_confirms_has_no_separate_loop_tuning():
    stated = default_sim_bench()
    r = stated.motor.phase_resistance_ohm
    result = Characterisation(identified=(_identified("phase_resistance_ohm", r * 1.001, r * 0.01),))
    measured = result.measured_config(stated)
    assert measured.loop_tuning is None and "loop_tuning" not in result.to_dict(stated)
    assert measured.model_point(500.0, 20.0).loop_motor == stated.motor


def test_an_already_tuned_bench_keeps_its_tuning():
    stated = default_sim_bench()
    nameplate = replace(stated.motor, phase_inductance_h=stated.motor.phase_inductance_h * 1.1)
    tuned = replace(stated, loop_tuning=nameplate)
    result = Characterisation(identified=(
        _identified("phase_resistance_ohm", stated.motor.phase_resistance_ohm * 1.3, 1e-4),))
    assert result.measured_config(tuned).loop_tuning == nameplate


def test_motor_bounds_span_the_measured_u_and_the_value_used():
    stated = default_sim_bench()
    r, ke = stated.motor.phase_resistance_ohm, stated.motor.ke_v_s_per_rad
    result = Characterisation(identified=(
        _identified("phase_resistance_ohm", r * 1.3, r * 0.01),      # disagrees: measured used
        _identified("ke_v_s_per_rad", ke * 1.001, ke * 0.002)))       # confirms: stated used
    bounds = result.motor_bounds(stated)
    assert bounds["phase_resistance_ohm"] == pytest.approx((r * 1.28, r * 1.32))
    assert bounds["ke_v_s_per_rad"] == pytest.approx((ke * 0.997, ke * 1.005))
    assert "phase_inductance_h" not in bounds                          # not measured
