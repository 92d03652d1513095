"""Transport faults on the simulated bench, each from the simulated instrument over its real
transport (Modbus TCP, CANopen on a virtual bus, serial pty), at a moment picked by wrapping a
driver method. For each: a typed error naming the instrument and the step, the drive left
disabled with every injection at its default (read back from the drive and seen on the twin),
and a record keeping every finished point and the raw data of the failed one if it was captured.

Not repeated here (tests/integration/test_safety.py and test_run.py cover them): the safe state
after a heartbeat loss and after an EMCY in one capture, a DAQ timeout on the first request,
Ctrl-C inside the guard, Ctrl-C of ``hil run`` keeping the record (test_sigint.py adds the bench
state after it).
"""

from __future__ import annotations

import math
import time

import pytest

from ripple_hil_drivers.errors import (DeviceFault, HeartbeatLost, InjectionRangeError, InstrumentError,
                            InstrumentTimeout, ProtocolError)
from ripple_hil_drivers.modbus_daq import DeviceFailure
from hil.bench import Bench
from hil.config import default_sim_bench
from hil.measurement import measure_point
from hil.record import RunRecord
from integration.test_safety import assert_safe

from .faults import assert_names, assert_recorded_failure, point, wrap

pytestmark = [pytest.mark.integration, pytest.mark.timeout(120)]


def assert_drive_safe(bench) -> None:
    """The drive-side half of assert_safe (for faults that take the DAQ away)."""
    assert bench.drive.state == "SWITCH ON DISABLED"
    injection = bench.drive.injection()
    limits = bench.drive.injection_limits()
    assert all(injection[knob] == default for knob, (_, _, default) in limits.items()), injection
    twin = bench.simulated.twin
    assert twin.enabled is False
    assert twin.injection == type(twin.injection)()


# ------------------------------------------------------------------------------ DAQ (Modbus)
def test_daq_server_disappears_mid_capture(sim_bench, run_record, monkeypatch):
    wrap(monkeypatch, sim_bench.daq, "wait_done", before=sim_bench.simulated.daq.stop)
    with pytest.raises(InstrumentError) as caught:
        measure_point(sim_bench, run_record, "daq-gone", point())
    assert_names(caught.value, "daq", "read")
    assert_drive_safe(sim_bench)
    report = sim_bench.safe_state_reports[-1]
    # the DAQ cannot be disarmed nor its dyno output zeroed: the safe-state report says so
    assert any(f.startswith("DAQ disarm") for f in report.failures), report.failures
    assert any(f.startswith("dyno speed reference") for f in report.failures), report.failures
    assert "drive disable (switch-on-disabled)" in report.steps
    assert "restore injection defaults (verified)" in report.steps
    assert_recorded_failure(sim_bench, run_record, "daq-gone", caught.value, captured=False)


def test_daq_connection_dropped_mid_capture_then_recovers(sim_bench, run_record, monkeypatch):
    wrap(monkeypatch, sim_bench.daq, "wait_done",
         before=lambda: sim_bench.simulated.daq.fail_next("disconnect"))
    with pytest.raises(InstrumentError) as caught:
        measure_point(sim_bench, run_record, "daq-dropped", point())
    assert_names(caught.value, "daq", "read state")
    assert_recorded_failure(sim_bench, run_record, "daq-dropped", caught.value, captured=False)
    # the server is still there: the guard's own DAQ steps reconnect and succeed
    assert_safe(sim_bench)
    outcome = measure_point(sim_bench, run_record, "after-drop", point())
    assert outcome.entry["outcome"] in ("passed", "failed")
    assert math.isfinite(outcome.result.pk_pk_pu)


def test_modbus_exception_reply_while_polling_the_capture(sim_bench, run_record, monkeypatch):
    wrap(monkeypatch, sim_bench.daq, "wait_done",
         before=lambda: sim_bench.simulated.daq.fail_next("exception"))
    with pytest.raises(DeviceFailure) as caught:
        measure_point(sim_bench, run_record, "daq-exception", point())
    assert caught.value.code == 4 and "Modbus exception 4" in str(caught.value)
    assert_names(caught.value, "daq", "read state")
    assert_safe(sim_bench)
    assert_recorded_failure(sim_bench, run_record, "daq-exception", caught.value, captured=False)


def test_modbus_exception_reply_to_the_dyno_speed_reference(sim_bench, run_record):
    sim_bench.simulated.daq.fail_next("exception")      # the point's first DAQ request
    with pytest.raises(DeviceFailure) as caught:
        measure_point(sim_bench, run_record, "dyno-refused", point())
    # the setpoint the dyno was given: the point's speed moved off the PWM carrier's lock
    setpoint = run_record.test("dyno-refused")["operating_point"]["dyno_speed_setpoint_rpm"]
    assert abs(setpoint / 500.0 - 1.0) <= 5e-3
    assert_names(caught.value, "daq", f"write dyno_speed_setpoint_rpm={float(setpoint)}")
    assert_safe(sim_bench)
    assert_recorded_failure(sim_bench, run_record, "dyno-refused", caught.value, captured=False)


def test_modbus_timeout_while_paging_the_buffer(sim_bench, run_record, monkeypatch):
    wrap(monkeypatch, sim_bench.daq, "read_buffer",
         before=lambda: sim_bench.simulated.daq.fail_next("timeout"))
    with pytest.raises(InstrumentTimeout) as caught:
        measure_point(sim_bench, run_record, "daq-page-timeout", point())
    assert_names(caught.value, "daq")
    assert f"{sim_bench.daq.timeout_s}" in caught.value.detail
    assert_safe(sim_bench)
    assert_recorded_failure(sim_bench, run_record, "daq-page-timeout", caught.value,
                            captured=False)


# ------------------------------------------------------------------------------ drive (CANopen)
def test_emcy_mid_sweep_keeps_the_finished_points(sim_bench, run_record, monkeypatch):
    """A 3-point sweep; the drive faults during the 2nd point's capture. The 1st point stays,
    the 2nd is recorded with its raw data, the 3rd is refused until the fault is reset."""
    wrap(monkeypatch, sim_bench.daq, "capture", on_call=2,
         after=lambda _: sim_bench.simulated.drive.raise_fault(0x4310, "hot"))
    first = measure_point(sim_bench, run_record, "sweep-1", point())
    with pytest.raises(DeviceFault) as caught:
        measure_point(sim_bench, run_record, "sweep-2", point(injection={"ia_offset_a": 0.8}))
    assert_names(caught.value, "drive", "check health")
    assert "0x4310" in caught.value.detail
    assert_safe(sim_bench, fault_allowed=True)
    assert sim_bench.drive.state == "FAULT"
    assert_recorded_failure(sim_bench, run_record, "sweep-2", caught.value, captured=True)
    with pytest.raises(DeviceFault, match="fault_reset"):
        measure_point(sim_bench, run_record, "sweep-3", point())
    assert_safe(sim_bench, fault_allowed=True)
    assert [t["test_id"] for t in run_record.tests] == ["sweep-1", "sweep-2", "sweep-3"]
    kept = run_record.tests[0]
    assert kept["outcome"] in ("passed", "failed") and kept["capture"]["sha256"]
    assert kept["measured"]["pk_pk_pu"] == pytest.approx(first.result.pk_pk_pu)
    assert sim_bench.drive.fault_reset() == "SWITCH ON DISABLED"
    measure_point(sim_bench, run_record, "sweep-3-again", point())
    assert run_record.tests[-1]["outcome"] in ("passed", "failed")
    assert run_record.tests[-1]["capture"]["sha256"]


def test_heartbeat_lost_mid_sweep_keeps_the_record(sim_bench, run_record, monkeypatch):
    """The drive's heartbeat stops during the 2nd point's capture (its SDO server still
    answers): the loss is seen at the health check after the capture, so the raw data is kept;
    the 1st point stays as it was. (test_safety.py checks the safe state for a loss before the
    capture; this one checks the record.)"""
    def silence(_):
        sim_bench.simulated.drive.stop_heartbeat()
        time.sleep(sim_bench.config.drive.heartbeat_timeout_s * 1.5)

    wrap(monkeypatch, sim_bench.daq, "capture", on_call=2, after=silence)
    measure_point(sim_bench, run_record, "hb-1", point())
    with pytest.raises(HeartbeatLost) as caught:
        measure_point(sim_bench, run_record, "hb-2", point())
    assert_names(caught.value, "drive", "check health")
    assert_safe(sim_bench)
    assert_recorded_failure(sim_bench, run_record, "hb-2", caught.value, captured=True)
    assert run_record.tests[0]["test_id"] == "hb-1"
    assert run_record.tests[0]["outcome"] in ("passed", "failed")


def test_sdo_abort_on_an_injection_write(sim_bench, run_record):
    """word_length_bits = 3 is inside the EDS limits (0..32) but the drive refuses 1..5: the
    simulated drive answers SDO abort 0x06090030 after ia_offset_a was already written."""
    plan = point(source="word_length", injection={"ia_offset_a": 0.5, "word_length_bits": 3})
    with pytest.raises(InjectionRangeError) as caught:
        measure_point(sim_bench, run_record, "sdo-abort", plan)
    assert_names(caught.value, "drive", "set injection word_length_bits=3", "0x2007")
    assert "0x06090030" in caught.value.detail.lower() or "6090030" in caught.value.detail
    assert_safe(sim_bench)          # ia_offset_a, written before the abort, is back to 0
    assert_recorded_failure(sim_bench, run_record, "sdo-abort", caught.value, captured=False)


# ------------------------------------------------------------------------------ transducer (serial)
def cross_check_with_transducer(bench, monkeypatch, readings: int = 20):
    """A plan step that reads the transducer after the capture is saved (inside the guard):
    the DAQ's analog torque is cross-checked against the transducer's serial readings."""
    def check(result=None):
        stream = bench.torque.stream(readings)
        assert len(stream) == readings and all(math.isfinite(r.torque_nm) for r in stream)
    wrap(monkeypatch, bench, "check_capture", after=check)


@pytest.mark.parametrize("fault, error_type, words", [
    ("garbage_lines", ProtocolError, ("stream 20 readings",)),
    ("silence", InstrumentTimeout, ("stream 20 readings",)),
])
def test_transducer_fault_during_a_point(sim_bench, run_record, monkeypatch, fault, error_type,
                                         words):
    simulated = sim_bench.simulated.torque
    cross_check_with_transducer(sim_bench, monkeypatch)
    if fault == "garbage_lines":        # a whole bad line before every answer
        simulated.inject_garbage(b"#%$ NOISE @@\r\n", responses=40)
    else:                               # the transducer stops answering
        simulated.drop_next(responses=40)
    with pytest.raises(error_type) as caught:
        measure_point(sim_bench, run_record, f"torque-{fault}", point())
    assert_names(caught.value, "torque", *words)
    assert_safe(sim_bench)
    assert_recorded_failure(sim_bench, run_record, f"torque-{fault}", caught.value, captured=True)
    # the instrument answers again: the driver recovers without reconnecting
    with simulated._switch_lock:
        simulated._garbage.clear()
        simulated._drop = 0
    assert math.isfinite(sim_bench.torque.read().torque_nm)


def test_transducer_corrupted_answer_is_asked_again_then_refused(sim_bench):
    """Neither dialect carries a checksum; a corrupted answer is one that fits no field. One bad
    answer is asked again (retries = 1); two in a row raise ProtocolError."""
    simulated = sim_bench.simulated.torque
    simulated.inject_garbage(b"S12T0.5X\r\n", responses=1)
    assert math.isfinite(sim_bench.torque.read().torque_nm)
    simulated.inject_garbage(b"S12T0.5X\r\n", responses=2)
    with pytest.raises(ProtocolError) as caught:
        sim_bench.torque.read()
    assert_names(caught.value, "torque", "read")
    assert "S12T0.5X" in caught.value.detail
    assert math.isfinite(sim_bench.torque.read().torque_nm)


def test_transducer_line_noise_and_partial_lines_are_tolerated(sim_bench):
    """Non-printable bytes before an answer, and answers arriving 3 bytes at a time, still give
    readings (drive disabled: the torque is zero within the transducer's noise and class, 0.1 %
    of 5 N·m = 5 mN·m)."""
    simulated = sim_bench.simulated.torque
    simulated.inject_garbage(responses=5)           # bytes 0x00 0xFF 0x13 0x7F 0xA5 ~?%
    noisy = [sim_bench.torque.read() for _ in range(5)]
    assert not simulated._garbage, "the noise was not all sent"
    simulated.fragment = True
    try:
        pieces = sim_bench.torque.stream(10)
    finally:
        simulated.fragment = False
    assert len(pieces) == 10
    for reading in noisy + pieces:
        assert abs(reading.torque_nm) < 0.01 and reading.speed_rpm == 0.0


# ------------------------------------------------------------------------------ DAQ on Modbus RTU
@pytest.fixture
def rtu_bench():
    """The simulated bench with its DAQ on Modbus RTU over a pty pair."""
    bench = Bench.open(default_sim_bench().with_overrides(
        {"daq": {"transport": "rtu", "requests_in_flight": 8}}), seed=4)   # 8: the default (TCP only)
    yield bench
    bench.close()


@pytest.fixture
def rtu_record(tmp_path, rtu_bench):
    record = RunRecord.create(tmp_path, rtu_bench.config, rtu_bench.identities())
    yield record
    record.finish("complete")


@pytest.mark.parametrize("kind, error_type", [("timeout", InstrumentTimeout),
                                              ("exception", DeviceFailure)])
def test_rtu_fault_mid_capture_then_the_line_recovers(rtu_bench, rtu_record, monkeypatch, kind,
                                                      error_type):
    """On a serial line a lost or refused answer must not leave the framing out of step: the
    guard's own DAQ requests and the next point go through on the same line."""
    assert rtu_bench.config.daq.transport == "rtu"
    wrap(monkeypatch, rtu_bench.daq, "wait_done",
         before=lambda: rtu_bench.simulated.daq.fail_next(kind))
    with pytest.raises(error_type) as caught:
        measure_point(rtu_bench, rtu_record, f"rtu-{kind}", point())
    assert_names(caught.value, "daq", "read state")
    assert_safe(rtu_bench)
    assert_recorded_failure(rtu_bench, rtu_record, f"rtu-{kind}", caught.value, captured=False)
    measure_point(rtu_bench, rtu_record, f"rtu-{kind}-after", point())
    assert rtu_record.tests[-1]["outcome"] in ("passed", "failed")


@pytest.fixture
def himmelstein_bench():
    bench = Bench.open(default_sim_bench().with_overrides({"torque": {"dialect": "himmelstein"}}),
                       seed=6)
    yield bench
    bench.close()


@pytest.mark.parametrize("how", ["read", "stream"])
def test_transducer_error_message_is_a_device_fault(himmelstein_bench, how):
    """An error message from the instrument (Himmelstein ``!...``) is a DeviceFault whether it
    answers a single request or arrives inside a stream — never skipped as line noise."""
    himmelstein_bench.simulated.torque.inject_garbage(b"!Overrange\r", responses=1)
    with pytest.raises(DeviceFault) as caught:
        if how == "read":
            himmelstein_bench.torque.read()
        else:
            himmelstein_bench.torque.stream(20)
    assert_names(caught.value, "torque", "read" if how == "read" else "stream 20 readings")
    assert "!Overrange" in caught.value.detail
    assert math.isfinite(himmelstein_bench.torque.read().torque_nm)
