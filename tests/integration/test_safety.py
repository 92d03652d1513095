"""Every exit path out of a measurement leaves the simulated bench safe (design.md §6).

Safe means, checked on the instruments themselves: the drive reports switch-on-disabled (or fault)
over CANopen, every injection reads back at its default, the twin behind the drive has its gates
off and its defaults restored, the DAQ is disarmed and the dyno speed reference is zero.
"""

import signal

import pytest

from ripple_hil_drivers.errors import DeviceFault, HeartbeatLost, InstrumentTimeout, LimitError
from hil.measurement import PointPlan, measure_point

INJECTION = {"ia_offset_a": 0.4, "dead_time_s": 1e-6, "word_length_bits": 12}


def plan(**overrides):
    settings = dict(source="dc_offset", injection={"ia_offset_a": 0.4, "ib_offset_a": 0.0},
                    speed_rpm=500.0, current_a=20.0, revolutions=3)
    return PointPlan(**(settings | overrides))


def assert_safe(bench, *, fault_allowed=False):
    states = {"SWITCH ON DISABLED"} | ({"FAULT"} if fault_allowed else set())
    assert bench.drive.state in states
    defaults = bench.drive.injection()
    assert defaults["ia_offset_a"] == 0.0 and defaults["dead_time_s"] == 0.0
    assert defaults["word_length_bits"] == 0 and defaults["encoder_decimation"] == 1
    twin = bench.simulated.twin
    assert twin.enabled is False
    assert twin.injection == type(twin.injection)()
    assert bench.daq.status()["state"] in ("idle", "disarmed")
    assert bench.daq.dyno_speed_rpm() == 0.0


def energise(bench):
    bench.drive.set_injection(**INJECTION)
    bench.daq.set_dyno_speed_rpm(300.0)
    bench.drive.set_current_command_a(10.0)
    bench.drive.enable()
    assert bench.simulated.twin.enabled
    assert bench.simulated.twin.injection.ia_offset_a == pytest.approx(0.4)


def test_exception_inside_the_guard_makes_the_bench_safe(sim_bench):
    energise(sim_bench)
    with pytest.raises(RuntimeError, match="plan bug"):
        with sim_bench.guard("step under test"):
            raise RuntimeError("plan bug")
    assert_safe(sim_bench)
    assert "plan bug" in sim_bench.safe_state_reports[-1].reason


def test_ctrl_c_inside_the_guard_makes_the_bench_safe(sim_bench):
    energise(sim_bench)
    with pytest.raises(KeyboardInterrupt):
        with sim_bench.guard("step under test"):
            signal.raise_signal(signal.SIGINT)
    assert_safe(sim_bench)


def test_limits_are_checked_before_any_command(sim_bench, run_record):
    with pytest.raises(LimitError, match="limits.current_a"):
        measure_point(sim_bench, run_record, "too-much-current", plan(current_a=80.0))
    twin = sim_bench.simulated.twin
    assert twin.enabled is False and twin.injection.ia_offset_a == 0.0
    assert run_record.tests[-1]["outcome"] == "error"


def test_limit_breach_seen_in_the_data(sim_bench, run_record):
    tight = sim_bench.config.with_overrides({"limits": {"current_a": 20.05}})
    sim_bench.config = tight      # 20 A commanded is allowed; the PWM ripple exceeds 20.05 A
    with pytest.raises(LimitError, match="ia_a|ib_a"):
        measure_point(sim_bench, run_record, "ripple-over-limit", plan())
    assert_safe(sim_bench)
    entry = run_record.tests[-1]
    assert entry["outcome"] == "error" and entry["capture"]["sha256"]   # raw data kept


def test_emcy_during_a_capture(sim_bench, run_record, monkeypatch):
    real_capture = sim_bench.daq.capture

    def capture_then_fault(*args, **kwargs):
        result = real_capture(*args, **kwargs)
        sim_bench.simulated.drive.raise_fault(0x2310, "overc")
        return result

    monkeypatch.setattr(sim_bench.daq, "capture", capture_then_fault)
    with pytest.raises(DeviceFault, match="0x2310|2310"):
        measure_point(sim_bench, run_record, "emcy", plan())
    assert_safe(sim_bench, fault_allowed=True)


def test_lost_heartbeat(sim_bench, run_record, monkeypatch):
    real_capture = sim_bench.daq.capture

    def capture_then_silence(*args, **kwargs):
        sim_bench.simulated.drive.stop_heartbeat()
        import time
        time.sleep(sim_bench.config.drive.heartbeat_timeout_s * 1.5)
        return real_capture(*args, **kwargs)

    monkeypatch.setattr(sim_bench.daq, "capture", capture_then_silence)
    with pytest.raises(HeartbeatLost):
        measure_point(sim_bench, run_record, "heartbeat", plan())
    assert_safe(sim_bench)


def test_daq_timeout_mid_capture(sim_bench, run_record):
    sim_bench.simulated.daq.fail_next("timeout")
    with pytest.raises(InstrumentTimeout):
        measure_point(sim_bench, run_record, "daq-timeout", plan())
    assert_safe(sim_bench)


def test_second_ctrl_c_during_make_safe_does_not_skip_steps(sim_bench, monkeypatch):
    energise(sim_bench)
    real_quick_stop = sim_bench.drive.quick_stop

    def interrupted_quick_stop(*args, **kwargs):
        real_quick_stop(*args, **kwargs)
        raise KeyboardInterrupt

    monkeypatch.setattr(sim_bench.drive, "quick_stop", interrupted_quick_stop)
    with pytest.raises(KeyboardInterrupt):
        sim_bench.make_safe("operator pressed Ctrl-C twice")
    monkeypatch.undo()
    assert_safe(sim_bench)
    assert "interrupted by Ctrl-C" in sim_bench.safe_state_reports[-1].failures[0]


def test_speed_over_its_limit_in_the_data(sim_bench, run_record, monkeypatch):
    sim_bench.config = sim_bench.config.with_overrides({"limits": {"speed_rpm": 600.0}})
    measure_point(sim_bench, run_record, "speed-within-limit", plan())     # 500 rpm: fine
    # a dyno that runs faster than the check before the command allowed: the data must catch it
    monkeypatch.setattr(sim_bench, "check_command", lambda **kwargs: None)
    with pytest.raises(LimitError, match="speed_rpm"):
        measure_point(sim_bench, run_record, "speed-over-limit", plan(speed_rpm=700.0))
    assert_safe(sim_bench)


def test_a_safe_state_failure_keeps_the_transport_error_as_its_cause(sim_bench, monkeypatch):
    """A bench killed during the safe state at a point's end: the SafeStateError carries the
    driver's typed error, so the run reports the bench lost in one line (it failed the point
    with a traceback, and only the next point named the lost bench; CI at bc689f5)."""
    from hil.bench import SafeStateError
    from ripple_hil_drivers.errors import TransportLost

    lost = TransportLost("drive", "quick stop", "[Errno 104] Connection reset by peer")

    def gone(*args, **kwargs):
        raise lost

    monkeypatch.setattr(sim_bench.drive, "quick_stop", gone)
    with pytest.raises(SafeStateError) as caught:
        sim_bench.make_safe("point finished")
    monkeypatch.undo()
    assert caught.value.__cause__ is lost
    assert_safe(sim_bench)
