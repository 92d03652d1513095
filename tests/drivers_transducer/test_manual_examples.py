"""The vendors' published example answers, fed byte for byte to the driver over a real pty.

Every answer string below is quoted from (or, where the manual prints only a format, built
exactly to) the public manual named beside it; see ``ripple_hil_drivers.transducer_dialects`` for the
sources. The scripted pty answers with these fixed bytes, so these tests do not depend on the
project's own simulator (which is checked against the same formats in
``test_transducer_integration.py``).
"""

from __future__ import annotations

import pytest

from ripple_hil_drivers.errors import DeviceFault, InstrumentTimeout
from ripple_hil_drivers.torque_transducer import SerialSettings, TorqueTransducer
from ripple_hil_drivers.transducer_dialects import LBF_IN_NM, TORQUE_UNIT_NM, float_to_hex
from hil.errors import InputError
from scripted_pty import ScriptedInstrument

pytestmark = [pytest.mark.integration, pytest.mark.timeout(30)]

OZ_IN_NM = TORQUE_UNIT_NM["oz.in"]


def magtrol(instrument, **options):
    return TorqueTransducer(SerialSettings(instrument.port), dialect="magtrol", timeout_s=0.3,
                            retries=0, dialect_options=options or None)


def test_dsp6000_example_padded_speed():
    # Magtrol DSP6000 manual, ch. 5 "Acquiring speed-torque data", example: "If a motor is
    # running at 1725 RPM clockwise, with the dynamometer loading the motor to 22.6 oz.in., the
    # DSP6000 will return: S 1725T22.60R"
    with ScriptedInstrument({"OD": b"S 1725T22.60R\r\n"}) as unit, \
            magtrol(unit, unit="oz.in") as tt:
        reading = tt.read()
    assert reading.speed_rpm == 1725.0
    assert reading.torque_nm == pytest.approx(22.6 * OZ_IN_NM, rel=1e-12)
    assert unit.received == ["UR0", "OD"]     # [6200] UR#: 0 = oz.in, set at connect


def test_6400_example_with_the_direction_digit():
    # Magtrol Model 6400 manual, §5.4 "Data format": "SdddddTdddd.RX<cr><lf>" and the example
    # "If a motor is running at 1725 rpm clockwise ... the 6400 will return: S 1725T22.60L1".
    # The letter is the documented shaft direction (L = counter-clockwise); the manual's prose
    # says clockwise, contradicting its own table, so the sign follows the letter and the digit
    # (direction input, "undefined" when that input is off) is accepted but not trusted.
    with ScriptedInstrument({"OD": b"S 1725T22.60L1\r\n"}) as unit, \
            magtrol(unit, unit="oz.in") as tt:
        reading = tt.read()
    assert reading.speed_rpm == -1725.0
    assert reading.torque_nm == pytest.approx(22.6 * OZ_IN_NM, rel=1e-12)


def test_dsp7000_channel_commands_and_six_character_speed():
    # Magtrol DSP7000 manual, §7.4.2: OD1 / OD2 "prompt to return speed-torque-direction data
    # string ... SxxxxxxTxxxxxR"; §7.2.1 format "SddddddTdddd.R(cr)(lf)", no leading zeroes;
    # §7.4.7 TS1 / TS2 "enables tare function".
    with ScriptedInstrument({"OD2": b"S  1725T22.60R\r\n"}) as unit, \
            magtrol(unit, channel=2, unit="oz.in") as tt:
        reading = tt.read()
        tt.tare()
        tt.read()                             # settings are silent: sync on an answer
    assert (reading.speed_rpm, reading.torque_nm) == (1725.0, pytest.approx(22.6 * OZ_IN_NM))
    assert unit.received == ["OD2", "TS2", "OD2"]    # no UR#: not in the DSP7000 command set


@pytest.mark.parametrize("alarm", [b"S 1725T22.60A\r\n", b"S  1725T22.60A\r\n",
                                   b"S1725T22.60A\r\n"])
def test_alarm_answers_are_device_faults_read_or_streamed(alarm):
    # Magtrol DSP6001 manual §8.6.2: "SxxxxxTxxxxxAcrlf ... A = alarm condition"; DSP7000 §7.2.1:
    # "When an "A" is in the R/L position (e.g. SdddddTdddd.A(cr)(lf)) ... alarm condition".
    with ScriptedInstrument({"OD": alarm}) as unit, magtrol(unit) as tt:
        with pytest.raises(DeviceFault, match="alarm"):
            tt.read()
        with pytest.raises(DeviceFault, match="alarm"):
            tt.stream(3)


def test_command_error_answer_is_a_device_fault():
    # Magtrol 3410 manual §5.2: "If a command is not recognized, a COMMAND ERROR CR-LF string
    # return will occur".
    with ScriptedInstrument({"OD": b"COMMAND ERROR\r\n"}) as unit, magtrol(unit) as tt:
        with pytest.raises(DeviceFault, match="COMMAND ERROR"):
            tt.read()


@pytest.mark.parametrize("idn, model", [(b"MAGTROL,DSP6001,S/N 1234,REV 2.0\r\n", "DSP6001"),
                                        (b"MAGTROL DSP7000 REV 1.04\r\n", "DSP7000")])
def test_identity_without_a_published_layout_is_parsed_tolerantly(idn, model):
    # DSP6001 §8.6.2 / DSP7000 §7.4.2: *IDN? "Returns Magtrol identification and software
    # revision" -- no layout is printed, so commas and plain words are both accepted.
    with ScriptedInstrument({"*IDN?": idn}) as unit, magtrol(unit) as tt:
        identity = tt.identity()
    assert identity["model"] == model and identity["idn"] == idn.decode().strip()


def test_unpublished_filter_command_is_never_sent():
    with ScriptedInstrument({"OD": b"S    0T0.000R\r\n"}) as unit, magtrol(unit) as tt:
        with pytest.raises(InputError, match="no filter command"):
            tt.set_filter(1)
        tt.read()                             # settings are silent: sync on an answer
    assert unit.received == ["UR8", "OD"]


def himmelstein(instrument):
    return TorqueTransducer(SerialSettings(instrument.port), dialect="himmelstein",
                            timeout_s=0.3, retries=0)


HIMMELSTEIN = {
    "DS": b"3F800000\r",                       # display scaling 1.0 (lbf-in), IEEE float hex
    "DC": b"1234.56\r",                        # MCRT 48200V guide, "Retrieve data" example
    "VR": b"Model MCRT48200V v1.2\r",          # "Retrieve the version number" example
    "MD": b"MCRT48200V\r", "SN": b"A1234\r",
    "FL": b"07\r",                             # "Retrieve the filter" example: 07 = 5 Hz
    "FL03": b"OK\r", "TT": b"OK\r",
    "FL01": b"!BadArg\r",                      # [NGRTM] error messages start with "!"
    f"DS{float_to_hex(LBF_IN_NM)}": b"!PasswordProtected\r",   # display scaling for N.m
}


def test_himmelstein_manual_examples():
    # Himmelstein MCRT 48200V guide, serial examples: "Send "DC" ... The return message should
    # look something like "1234.56""; VR -> "Model MCRT48200V v1.2"; FL -> "07" (5 Hz).
    # Messages end with <CR>; 38400 baud 8N1 ([NGRTM] appendix IV).
    with ScriptedInstrument(HIMMELSTEIN) as unit, himmelstein(unit) as tt:
        assert tt.settings.baudrate == 38400 and tt.settings.parity == "N"
        reading = tt.read()
        identity = tt.identity()
        assert tt.query("FL") == "07"
        tt.set_filter(3)                       # the table: 3 = 100 Hz
        tt.tare()
        with pytest.raises(DeviceFault, match="!BadArg"):
            tt._transaction("set filter", lambda: tt.query("FL01"))
    assert reading.torque_nm == pytest.approx(1234.56 * LBF_IN_NM, rel=1e-9)
    assert reading.speed_rpm is None and reading.time_s is None
    assert identity == {"vendor": "Himmelstein", "model": "MCRT48200V", "serial_number": "A1234",
                        "firmware": "Model MCRT48200V v1.2"}
    assert unit.received[:2] == ["DS", "DC"] and "YC" not in unit.received
    assert "FL03" in unit.received and "TT" in unit.received


def test_himmelstein_refused_setting_is_a_device_fault():
    with ScriptedInstrument(HIMMELSTEIN) as unit, himmelstein(unit) as tt:
        with pytest.raises(DeviceFault, match="PasswordProtected"):
            tt.set_units("N.m")


def test_family_line_defaults_and_unpublished_rates():
    # Magtrol DSP6000 manual ch. 5: 300 ... 19200 baud, no parity, 8 data bits, 1 stop bit.
    magtrol_tt = TorqueTransducer(SerialSettings("/dev/null"), dialect="magtrol")
    assert (magtrol_tt.settings.baudrate, magtrol_tt.settings.bytesize,
            magtrol_tt.settings.parity, magtrol_tt.settings.stopbits) == (19200, 8, "N", 1)
    assert TorqueTransducer(SerialSettings("/dev/null", baudrate=300)).settings.baudrate == 300
    with pytest.raises(InputError, match="baudrate=115200 .* magtrol"):
        TorqueTransducer(SerialSettings("/dev/null", baudrate=115200), dialect="magtrol")
    with pytest.raises(InputError, match="baudrate=19200 .* himmelstein"):
        TorqueTransducer(SerialSettings("/dev/null", baudrate=19200), dialect="himmelstein")


def test_silence_is_a_timeout_not_a_reading():
    with ScriptedInstrument({}) as unit, magtrol(unit) as tt:
        with pytest.raises(InstrumentTimeout):
            tt.read()


def test_bench_file_baudrate_follows_the_dialect_and_the_record_states_it():
    from hil.config import default_sim_bench
    bench = default_sim_bench()
    assert "baudrate" not in bench.raw["torque"]
    assert bench.torque.baudrate == 19200 and bench.to_dict()["torque"]["baudrate"] == 19200
    himmelstein = bench.with_overrides({"torque": {"dialect": "himmelstein"}})
    assert himmelstein.torque.baudrate == 38400
    with pytest.raises(InputError, match="torque.baudrate = 115200 is not published for the "
                                         "magtrol dialect"):
        bench.with_overrides({"torque": {"baudrate": 115200}})
    with pytest.raises(InputError, match="torque.baudrate = 19200 .* himmelstein"):
        bench.with_overrides({"torque": {"dialect": "himmelstein", "baudrate": 19200}})
    assert bench.with_overrides({"torque": {"baudrate": 300}}).torque.baudrate == 300
