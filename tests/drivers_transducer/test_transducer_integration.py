"""The simulated transducer driven through pyserial over a pseudo-terminal, both dialects."""

from __future__ import annotations

import re
import time

import numpy as np
import pytest

from ripple_hil_drivers.errors import DeviceFault, InstrumentTimeout, ProtocolError
from ripple_hil_drivers.simulated.transducer_pty import SimulatedTransducer
from ripple_hil_drivers.torque_transducer import SerialSettings, TorqueTransducer
from hil.errors import InputError
from hil.motor import TABLE_I

pytestmark = [pytest.mark.integration, pytest.mark.timeout(60)]

DIALECTS = ("magtrol", "himmelstein")
RATE_HZ = 1000.0
EXPECTED_TORQUE_NM = TABLE_I.torque_constant_nm_per_a * 10.0      # twin at 10 A


@pytest.fixture(params=DIALECTS)
def rig(request, twin):
    with SimulatedTransducer(twin, dialect=request.param, sample_rate_hz=RATE_HZ) as sim, \
            TorqueTransducer(SerialSettings(sim.port), dialect=request.param,
                             timeout_s=0.3) as tt:
        yield sim, tt


def test_identity_names_the_instrument(rig):
    sim, tt = rig
    identity = tt.identity()
    assert identity["serial_number"] == "SIM-TQ-0001"
    assert identity["vendor"] == {"magtrol": "Magtrol", "himmelstein": "Himmelstein"}[
        sim.dialect]


def test_readings_come_from_the_twin_one_sample_period_each(rig, twin):
    sim, tt = rig
    start_s = twin.time_s
    readings = tt.stream(200)
    assert len(readings) == 200
    assert twin.time_s - start_s == pytest.approx(200 / RATE_HZ, rel=1e-6)
    torque = np.array([r.torque_nm for r in readings])
    assert np.mean(torque) == pytest.approx(EXPECTED_TORQUE_NM, rel=0.2)
    if sim.dialect == "magtrol":
        assert all(r.speed_rpm == pytest.approx(twin.speed_rpm, abs=0.5) for r in readings)
        last = tt.read()      # no filter: the wire value is the twin's, to the field's 1 mN*m
        assert last.torque_nm == pytest.approx(twin.status()["torque_nm"], abs=0.51e-3)
    else:
        assert all(r.speed_rpm is None and r.time_s is None for r in readings)   # DC


def test_units_change_the_wire_not_the_si_reading(rig):
    _, tt = rig
    before = np.mean([r.torque_nm for r in tt.stream(50)])
    tt.set_units("lb.in")
    after = np.mean([r.torque_nm for r in tt.stream(50)])
    assert after == pytest.approx(before, rel=0.05)
    with pytest.raises(InputError, match="furlong"):
        tt.set_units("furlong.in")


def test_tare_zeroes_the_reading(twin):
    with SimulatedTransducer(twin, dialect="magtrol", magtrol_model="DSP7000") as dsp7000, \
            TorqueTransducer(SerialSettings(dsp7000.port), dialect="magtrol", timeout_s=0.3,
                             dialect_options={"channel": 1, "unit": "oz.in"}) as magtrol, \
            SimulatedTransducer(twin, dialect="himmelstein") as mcrt, \
            TorqueTransducer(SerialSettings(mcrt.port), dialect="himmelstein") as himmelstein:
        for tt in (magtrol, himmelstein):
            assert abs(tt.read().torque_nm) > 0.5 * EXPECTED_TORQUE_NM
            tt.tare()
            assert abs(np.mean([r.torque_nm for r in tt.stream(20)])) < 0.1 * EXPECTED_TORQUE_NM


def test_single_channel_magtrol_has_no_published_tare_or_filter(twin):
    with SimulatedTransducer(twin, dialect="magtrol") as sim, \
            TorqueTransducer(SerialSettings(sim.port), dialect="magtrol") as tt:
        with pytest.raises(InputError, match="no tare command"):
            tt.tare()
        with pytest.raises(InputError, match="no filter command"):
            tt.set_filter(1)


def test_himmelstein_filter_codes_are_checked_and_applied(twin):
    with SimulatedTransducer(twin, dialect="himmelstein") as sim, \
            TorqueTransducer(SerialSettings(sim.port), dialect="himmelstein") as tt:
        assert tt.query("FL") == "06"                  # factory default 10 Hz
        tt.set_filter(3)
        assert sim.instrument.filter.cutoff_hz == 100.0
        with pytest.raises(InputError, match="filter code=99"):
            tt.set_filter(99)
        with pytest.raises(DeviceFault, match="!BadArg"):
            tt._transaction("set filter", lambda: tt.dialect.set_filter(tt, 1))


def test_garbage_partial_lines_and_silence_are_handled(rig):
    sim, tt = rig
    sim.inject_garbage(responses=1)
    assert tt.read().torque_nm == pytest.approx(EXPECTED_TORQUE_NM, rel=0.2)
    sim.inject_garbage(b"#*\r", responses=1)         # a whole garbage line: asked again
    assert tt.read().torque_nm == pytest.approx(EXPECTED_TORQUE_NM, rel=0.2)
    sim.inject_garbage(b"#*\r", responses=2)         # twice: retries exhausted
    with pytest.raises(ProtocolError, match="^torque: read"):
        tt.read()
    sim.fragment = True
    assert tt.read().torque_nm == pytest.approx(EXPECTED_TORQUE_NM, rel=0.2)
    sim.fragment = False
    sim.drop_next()
    with pytest.raises(InstrumentTimeout, match="no complete answer"):
        tt.read()
    assert tt.read().torque_nm == pytest.approx(EXPECTED_TORQUE_NM, rel=0.2)
    sim.inject_garbage(b"zz\r", responses=3)         # bad lines inside a stream are replaced
    assert len(tt.stream(64)) == 64


def test_magtrol_alarm_becomes_a_device_fault(twin):
    with SimulatedTransducer(twin, dialect="magtrol", rated_torque_nm=0.1) as sim, \
            TorqueTransducer(SerialSettings(sim.port), dialect="magtrol") as tt:
        with pytest.raises(DeviceFault, match="alarm"):
            tt.read()                       # 0.49 N*m on a 0.1 N*m transducer: alarm


def raw_answer(port: str, command: bytes, terminator: bytes) -> bytes:
    """The simulator's answer bytes to one command, read with plain pyserial (no driver)."""
    import serial
    with serial.Serial(port, timeout=0.5) as line:
        line.write(command)
        return line.read_until(terminator)


# The manuals' printed formats (see drivers.transducer_dialects for the sources): fixed-length
# fields, the speed right-aligned with spaces ("no leading zeroes"), the torque with a point.
MAGTROL_FORMATS = {
    "DSP6001": (b"OD\r\n", rb"S(?! *0\d)[ \d]{4}\dT(?=[ \d.]{5}[RLA])[ \d]*\.\d*[RLA]\r\n"),
    "DSP7000": (b"OD1\r\n", rb"S(?! *0\d)[ \d]{5}\dT(?=[ \d.]{5}[RLA])[ \d]*\.\d*[RLA]\r\n"),
    "6400": (b"OD\r\n", rb"S(?! *0\d)[ \d]{4}\dT(?=[ \d.]{5}[RLA])[ \d]*\.\d*[RLA][01]\r\n"),
}


@pytest.mark.parametrize("model", sorted(MAGTROL_FORMATS))
def test_simulated_magtrol_answers_in_the_printed_format(twin, model):
    command, pattern = MAGTROL_FORMATS[model]
    twin.speed_rpm = 725.0
    with SimulatedTransducer(twin, dialect="magtrol", magtrol_model=model) as sim:
        answer = raw_answer(sim.port, command, b"\n")
        assert re.fullmatch(pattern, answer), answer
        twin.speed_rpm = 0.0
        assert re.fullmatch(pattern, raw_answer(sim.port, command, b"\n"))
    assert answer.startswith(b"S  725T" if model != "DSP7000" else b"S   725T")


def test_simulated_himmelstein_answers_in_the_printed_format(twin):
    with SimulatedTransducer(twin, dialect="himmelstein") as sim:
        assert re.fullmatch(rb"-?\d+\.\d+\r", raw_answer(sim.port, b"DC\r", b"\r"))
        assert raw_answer(sim.port, b"VR\r", b"\r") == b"Model MCRT48200V v1.2\r"
        assert raw_answer(sim.port, b"QQ\r", b"\r") == b"!QQ\r"


def test_pacing_to_the_baud_rate_costs_line_time(twin):
    baud = 9600
    with SimulatedTransducer(twin, dialect="magtrol", pace_baud=baud) as sim, \
            TorqueTransducer(SerialSettings(sim.port, baudrate=baud), dialect="magtrol") as tt:
        start = time.perf_counter()
        tt.stream(10)
        elapsed = time.perf_counter() - start
    line_bytes = 10 * (len("OD\r\n") + len("S 1000T0.488R\r\n"))
    assert elapsed >= 0.9 * line_bytes * 10 / baud


def test_opening_a_missing_port_names_the_instrument(tmp_path):
    from ripple_hil_drivers.errors import InstrumentError
    with pytest.raises(InstrumentError, match="^torque: connect"):
        TorqueTransducer(SerialSettings(str(tmp_path / "no-such-tty"))).connect()


def test_transducer_and_daq_share_one_simulated_run(twin):
    from ripple_hil_drivers.modbus_daq import ModbusDaq, ModbusTcpSettings
    from ripple_hil_drivers.simulated.modbus_daq_server import SimulatedDaq
    with SimulatedDaq(twin) as daq_server, \
            ModbusDaq(ModbusTcpSettings(*daq_server.address)) as daq, \
            SimulatedTransducer(twin, dialect="himmelstein", sample_rate_hz=RATE_HZ) as sim, \
            TorqueTransducer(SerialSettings(sim.port), dialect="himmelstein",
                             dialect_options={"timestamped": True}) as tt:
        before = tt.read().time_s
        capture = daq.capture(0.1, 10000, settle_s=0.02)
        after = tt.read().time_s
        # the DAQ's settle + capture advanced the same twin the transducer reads from
        assert after - before == pytest.approx(0.02 + 0.1 + 1 / RATE_HZ, abs=2e-4)
        readings = tt.stream(100)
        assert np.allclose(np.diff([r.time_s for r in readings]), 1 / RATE_HZ)
        assert np.mean([r.torque_nm for r in readings]) == pytest.approx(
            np.mean(capture["torque_nm"]), rel=0.05)
