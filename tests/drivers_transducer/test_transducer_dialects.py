"""Unit tests of the two transducer dialects' parsing and unit conversion (no I/O)."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from drivers.transducer_dialects import (LBF_IN_NM, TORQUE_UNIT_NM, DeviceReportedError,
                                         DialectError, HimmelsteinDialect, MagtrolDialect,
                                         float_to_hex, hex_to_float, hex_to_int16)


def test_unit_factors_follow_from_the_inch_pound_and_kilogram_force():
    inch_m, pound_force_n, kgf_n = 0.0254, 4.4482216152605, 9.80665
    assert TORQUE_UNIT_NM["lb.in"] == pytest.approx(inch_m * pound_force_n, rel=1e-9)
    assert TORQUE_UNIT_NM["lb.ft"] == pytest.approx(12 * inch_m * pound_force_n, rel=1e-9)
    assert TORQUE_UNIT_NM["oz.in"] == pytest.approx(inch_m * pound_force_n / 16, rel=1e-9)
    assert TORQUE_UNIT_NM["oz.ft"] == pytest.approx(12 * inch_m * pound_force_n / 16, rel=1e-9)
    assert TORQUE_UNIT_NM["kg.cm"] == pytest.approx(kgf_n / 100, rel=1e-12)
    assert TORQUE_UNIT_NM["g.cm"] == pytest.approx(kgf_n / 1e5, rel=1e-12)


def test_magtrol_od_answer_gives_signed_speed_and_si_torque():
    dialect = MagtrolDialect()
    reading = dialect.parse_reading("S1500T0.4879R")
    assert (reading.speed_rpm, reading.torque_nm, reading.time_s) == (1500.0, 0.4879, None)
    assert dialect.parse_reading("S20T-1.2500L").speed_rpm == -20.0
    dialect.unit = "lb.in"
    assert dialect.parse_reading("S1T2.0000R").torque_nm == pytest.approx(2 * LBF_IN_NM)


def test_magtrol_tolerates_line_noise_before_the_answer_but_not_a_broken_answer():
    dialect = MagtrolDialect()
    assert dialect.parse_reading("~?%S100T0.1000R").torque_nm == 0.1
    for broken in ("S100T0.1000", "S100R", "T0.1R", "S1x0T0.1R", ""):
        with pytest.raises(DialectError):
            dialect.parse_reading(broken)


def test_magtrol_alarm_is_a_device_report():
    with pytest.raises(DeviceReportedError, match="alarm"):
        MagtrolDialect().parse_reading("S100T9.9999A")


@given(st.floats(-1e6, 1e6, width=32))
def test_ieee_hex_round_trips(value):
    assert hex_to_float(float_to_hex(value)) == value


def test_hex_counts_are_16_bit_twos_complement():
    assert hex_to_int16("7FFF") == 32767
    assert hex_to_int16("8000") == -32768
    assert hex_to_int16("FFFF") == -1
    with pytest.raises(DialectError):
        hex_to_int16("12G4")


def test_himmelstein_yc_uses_the_scaling_constants_and_unwraps_the_tick_counter():
    dialect = HimmelsteinDialect()
    dialect.scale_pos_lbf_in, dialect.scale_neg_lbf_in = 0.002, 0.004
    first = dialect.parse_reading("FFFFFFF6,0064")        # 10 ticks before the wrap, +100
    second = dialect.parse_reading("00000004,FF9C")        # 4 ticks after it, -100
    assert first.torque_nm == pytest.approx(100 * 0.002 * LBF_IN_NM)
    assert second.torque_nm == pytest.approx(-100 * 0.004 * LBF_IN_NM)
    assert second.time_s - first.time_s == pytest.approx(14 / 10_000)
    assert first.speed_rpm is None
    with pytest.raises(DialectError):
        dialect.parse_reading("0000000,0064")               # 7-digit time stamp
