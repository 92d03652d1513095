"""The simulated transducer driven through pyserial over a pseudo-terminal, both dialects."""

from __future__ import annotations

import time

import numpy as np
import pytest

from drivers.errors import DeviceFault, InstrumentTimeout, ProtocolError
from drivers.simulated.transducer_pty import SimulatedTransducer
from drivers.torque_transducer import SerialSettings, TorqueTransducer
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
        last = tt.read()                    # filter off: the wire value is the twin's, rounded
        assert last.torque_nm == pytest.approx(twin.status()["torque_nm"], abs=0.6e-4)
    else:
        stamps = np.array([r.time_s for r in readings])
        assert np.allclose(np.diff(stamps), 1 / RATE_HZ)
        assert stamps[-1] == pytest.approx(twin.time_s, abs=1e-4)


def test_units_change_the_wire_not_the_si_reading(rig):
    _, tt = rig
    before = np.mean([r.torque_nm for r in tt.stream(50)])
    tt.set_units("lb.in")
    after = np.mean([r.torque_nm for r in tt.stream(50)])
    assert after == pytest.approx(before, rel=0.05)
    with pytest.raises(InputError, match="furlong"):
        tt.set_units("furlong.in")


def test_tare_zeroes_the_reading(rig):
    _, tt = rig
    assert abs(tt.read().torque_nm) > 0.5 * EXPECTED_TORQUE_NM
    tt.tare()
    assert abs(np.mean([r.torque_nm for r in tt.stream(20)])) < 0.1 * EXPECTED_TORQUE_NM


def test_filter_codes_are_checked_and_applied(rig):
    sim, tt = rig
    code = {"magtrol": 4, "himmelstein": 3}[sim.dialect]
    tt.set_filter(code)
    tt.read()                               # Magtrol settings are silent: sync on an answer
    assert sim.instrument.filter.cutoff_hz == {"magtrol": 50.0, "himmelstein": 100.0}[
        sim.dialect]
    with pytest.raises(InputError, match="filter code=99"):
        tt.set_filter(99)


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


def test_instrument_errors_become_device_faults(twin):
    with SimulatedTransducer(twin, dialect="magtrol", rated_torque_nm=0.1) as sim, \
            TorqueTransducer(SerialSettings(sim.port), dialect="magtrol") as tt:
        with pytest.raises(DeviceFault, match="alarm"):
            tt.read()                       # 0.49 N*m on a 0.1 N*m transducer: alarm
    with SimulatedTransducer(twin, dialect="himmelstein") as sim, \
            TorqueTransducer(SerialSettings(sim.port), dialect="himmelstein") as tt:
        assert tt.query("FL") == "02"
        with pytest.raises(DeviceFault, match="!BadArg"):
            tt._transaction("set filter", lambda: tt.dialect.set_filter(tt, 1))


def test_pacing_to_the_baud_rate_costs_line_time(twin):
    baud = 9600
    with SimulatedTransducer(twin, dialect="magtrol", pace_baud=baud) as sim, \
            TorqueTransducer(SerialSettings(sim.port, baudrate=baud), dialect="magtrol") as tt:
        start = time.perf_counter()
        tt.stream(10)
        elapsed = time.perf_counter() - start
    line_bytes = 10 * (len("OD\r\n") + len("S1000T0.4879R\r\n"))
    assert elapsed >= 0.9 * line_bytes * 10 / baud


def test_opening_a_missing_port_names_the_instrument(tmp_path):
    from drivers.errors import InstrumentError
    with pytest.raises(InstrumentError, match="^torque: connect"):
        TorqueTransducer(SerialSettings(str(tmp_path / "no-such-tty"))).connect()


def test_transducer_and_daq_share_one_simulated_run(twin):
    from drivers.modbus_daq import ModbusDaq, ModbusTcpSettings
    from drivers.simulated.modbus_daq_server import SimulatedDaq
    with SimulatedDaq(twin) as daq_server, \
            ModbusDaq(ModbusTcpSettings(*daq_server.address)) as daq, \
            SimulatedTransducer(twin, dialect="himmelstein", sample_rate_hz=RATE_HZ) as sim, \
            TorqueTransducer(SerialSettings(sim.port), dialect="himmelstein") as tt:
        before = tt.read().time_s
        capture = daq.capture(0.1, 10000, settle_s=0.02)
        after = tt.read().time_s
        # the DAQ's settle + capture advanced the same twin the transducer reads from
        assert after - before == pytest.approx(0.02 + 0.1 + 1 / RATE_HZ, abs=2e-4)
        assert np.mean([r.torque_nm for r in tt.stream(100)]) == pytest.approx(
            np.mean(capture["torque_nm"]), rel=0.05)
