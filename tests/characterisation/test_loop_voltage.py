"""The loop test signal is not sent where it would take the drive beyond its linear voltage: a
saturated loop reads slow and failed correct drives as "a finding about the drive under test"
(Table I 1500 rpm / 30 A: g = 0.375 ± 0.112; the 2-pole 24 V motor at 1089 rpm / 20 A: 0.514)."""

import math

import pytest

from hil.bench import Bench
from hil.characterisation.stage import loop_test_voltage_v, run_stage
from hil.config import OperatingPoint, default_sim_bench
from hil.record import RunRecord

PLANT = (0.055, 38.5e-6)          # Table I: R Ω, L H
PSI = 0.023 * math.sqrt(2)        # peak phase EMF per mechanical rad/s (Ke RMS phase)


def test_the_test_signal_voltage_adds_the_test_current_through_the_winding():
    op = OperatingPoint(speed_rpm=1500.0, current_a=30.0)
    steady = loop_test_voltage_v(op, 2, 8, 0.0, PLANT, PSI)
    omega_e = 2 * 1500 * 2 * math.pi / 60
    # current on q (φ = 0): v = (R + jωe·L)·jI + jE = −ωe·L·I + j(R·I + E)
    emf_v = PSI * omega_e / 2
    assert steady == pytest.approx(math.hypot(omega_e * 38.5e-6 * 30, 0.055 * 30 + emf_v))
    extra = loop_test_voltage_v(op, 2, 32, 3.0, PLANT, PSI) - steady
    assert extra == pytest.approx(3.0 * abs(complex(0.055, 33 * omega_e * 38.5e-6)))


@pytest.mark.parametrize("speed_rpm, current_a, identified", [(1500.0, 30.0, False),
                                                               (500.0, 20.0, True)])
def test_the_loop_is_measured_only_within_the_linear_voltage(tmp_path, speed_rpm, current_a,
                                                            identified):
    config = default_sim_bench().with_overrides(
        {"operating_point": {"speed_rpm": speed_rpm, "current_a": current_a}})
    bench = Bench.open(config, seed=1)
    record = RunRecord.create(tmp_path, config, bench.identities())
    try:
        result = run_stage(bench, record)
    finally:
        record.finish("complete")
        bench.close()
    assert (result.get("current_loop_gain_pu") is not None) is identified
    if not identified:
        reason = result.not_identified["current_loop_bandwidth_hz"]
        assert "beyond its linear voltage 6.93 V" in reason
        assert not any(name.startswith("characterisation-loop")
                       for name in (c["test_id"] for c in record.data["pending_captures"]))
