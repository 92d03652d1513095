"""Unit tests of the two transducer dialects' parsing and unit conversion (no I/O)."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from ripple_hil_drivers.transducer_dialects import (LBF_IN_NM, TORQUE_UNIT_NM, DeviceReportedError,
                                         DialectError, HimmelsteinDialect, MagtrolDialect,
                                         float_to_hex, hex_to_float, hex_to_int16)
from hil.errors import InputError


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
    reading = dialect.parse_reading("S 1500T0.488R")
    assert (reading.speed_rpm, reading.torque_nm, reading.time_s) == (1500.0, 0.488, None)
    assert dialect.parse_reading("S   20T-1.250L").speed_rpm == -20.0
    assert dialect.parse_reading("S   20T -1.25L").torque_nm == -1.25
    dialect.unit = "lb.in"
    assert dialect.parse_reading("S    1T2.000R").torque_nm == pytest.approx(2 * LBF_IN_NM)


def test_magtrol_tolerates_line_noise_before_the_answer_but_not_a_broken_answer():
    dialect = MagtrolDialect()
    assert dialect.parse_reading("~?%S  100T0.100R").torque_nm == 0.1
    for broken in ("S100T0.1000", "S100R", "T0.1R", "S1x0T0.1R", "", "S12T0.5X", "S100T12R",
                   "S100T.R", "S100T0.1R2"):
        with pytest.raises(DialectError):
            dialect.parse_reading(broken)


def test_magtrol_alarm_is_a_device_report_padded_or_not():
    for alarm in ("S100T9.9999A", "S  100T9.999A", "S   100T 9.99A"):
        with pytest.raises(DeviceReportedError, match="alarm"):
            MagtrolDialect().parse_reading(alarm)


def test_magtrol_channel_selects_the_dsp7000_commands():
    assert MagtrolDialect().read_command == "OD"
    assert MagtrolDialect(channel=1).read_command == "OD1"
    assert MagtrolDialect(channel=2).read_command == "OD2"
    with pytest.raises(InputError, match="channel=3"):
        MagtrolDialect(channel=3)
    with pytest.raises(InputError, match="unit='furlong'"):
        MagtrolDialect(unit="furlong")


class Recorder:
    """Stands in for the driver's send/query (unit test): records what a dialect sends."""

    def __init__(self, answers=None):
        self.sent, self.answers = [], dict(answers or {})

    def send(self, command):
        self.sent.append(command)

    def query(self, command):
        self.sent.append(command)
        return self.answers[command]


def test_magtrol_sends_only_published_commands():
    single, dsp7000 = MagtrolDialect(), MagtrolDialect(channel=2)
    io = Recorder()
    single.setup(io)
    single.set_units(io, "oz.in")
    dsp7000.setup(io)
    dsp7000.tare(io)
    assert io.sent == ["UR8", "UR0", "TS2"]        # [6200] UR#, [DSP7000] TS2
    with pytest.raises(InputError, match="no filter command"):
        single.set_filter(io, 1)
    with pytest.raises(InputError, match="no tare command"):
        single.tare(io)
    with pytest.raises(InputError, match="no readout-unit command"):
        dsp7000.set_units(io, "N.m")
    assert io.sent == ["UR8", "UR0", "TS2"]


@pytest.mark.parametrize("idn, model, serial, firmware", [
    ("MAGTROL,DSP7000,12345,REV 1.04", "DSP7000", "12345", "REV 1.04"),
    ("MAGTROL DSP6001 REV 2.01", "DSP6001", "", "REV 2.01"),
    ("Magtrol,6400", "6400", "", ""),
    ("MAGTROL", "", "", ""),
])
def test_magtrol_identity_is_parsed_tolerantly(idn, model, serial, firmware):
    identity = MagtrolDialect().identity(Recorder({"*IDN?": idn}))
    assert (identity["model"], identity["serial_number"], identity["firmware"]) == (
        model, serial, firmware)
    assert identity["idn"] == idn and identity["vendor"] == "Magtrol"


def test_magtrol_identity_refuses_an_error_answer():
    with pytest.raises(DeviceReportedError, match="COMMAND ERROR"):
        MagtrolDialect().identity(Recorder({"*IDN?": "COMMAND ERROR"}))


@given(st.floats(-1e6, 1e6, width=32))
def test_ieee_hex_round_trips(value):
    assert hex_to_float(float_to_hex(value)) == value


def test_hex_counts_are_16_bit_twos_complement():
    assert hex_to_int16("7FFF") == 32767
    assert hex_to_int16("8000") == -32768
    assert hex_to_int16("FFFF") == -1
    with pytest.raises(DialectError):
        hex_to_int16("12G4")


def test_himmelstein_dc_is_display_units_over_the_display_scaling():
    dialect = HimmelsteinDialect()
    dialect.setup(Recorder({"DS": float_to_hex(2.0)}))     # display units = 2 x lbf-in
    reading = dialect.parse_reading("-24.5")
    assert reading.torque_nm == pytest.approx(-12.25 * LBF_IN_NM)
    assert (reading.speed_rpm, reading.time_s) == (None, None)
    for broken in ("", "1.2.3", "0x64", "OK", "12,5"):
        with pytest.raises(DialectError):
            dialect.parse_reading(broken)
    with pytest.raises(DialectError, match="display scaling"):
        HimmelsteinDialect().setup(Recorder({"DS": float_to_hex(-1.0)}))


def test_himmelstein_sends_dc_by_default_and_yc_only_when_asked():
    assert HimmelsteinDialect().read_command == "DC"
    io = Recorder({"DS": float_to_hex(1.0), "SC": float_to_hex(0.002) + float_to_hex(0.004)})
    HimmelsteinDialect().setup(io)
    assert io.sent == ["DS"]
    timestamped = HimmelsteinDialect(timestamped=True)
    timestamped.setup(io)
    assert io.sent == ["DS", "DS", "SC"] and timestamped.read_command == "YC"


def test_himmelstein_yc_uses_the_scaling_constants_and_unwraps_the_tick_counter():
    dialect = HimmelsteinDialect(timestamped=True)
    dialect.scale_pos_lbf_in, dialect.scale_neg_lbf_in = 0.002, 0.004
    first = dialect.parse_reading("FFFFFFF6,0064")        # 10 ticks before the wrap, +100
    second = dialect.parse_reading("00000004, FF9C")       # 4 ticks after it, -100
    assert first.torque_nm == pytest.approx(100 * 0.002 * LBF_IN_NM)
    assert second.torque_nm == pytest.approx(-100 * 0.004 * LBF_IN_NM)
    assert second.time_s - first.time_s == pytest.approx(14 / 10_000)
    assert first.speed_rpm is None
    with pytest.raises(DialectError):
        dialect.parse_reading("000000000,0064")             # 9-digit time stamp
