"""Issue 22.1: a long-lived simulated bench gives the self-check the same current reading.

Root cause: the self-check captures at 8 kHz against the drive's 20 kHz PWM (commensurate: only
two sample phases within the PWM period), so the switching ripple aliases into the phase
currents' fundamental by an amount set by that phase; the simulated DAQ started sampling at the
trigger instant, whose phase within the PWM period depended on all the simulated time the bench
had run. Now its first sample falls on a PWM counter valley. Each test captures through the real
Modbus TCP client and judges with ``hil.selfcheck.current_channels`` (the self-check's own
check, 2 % tolerance).
"""

from __future__ import annotations

import math

import pytest

from hil.selfcheck import current_channels
from hil.sim import DriveTwin
from hil.sim import layout as L

SPEED_RPM = 500.0
CURRENT_A = 20.0
RATE_HZ = 8000.0                   # the self-check's rate at 500 rpm (hil.measurement)
DURATION_S = 3960 / RATE_HZ
POLE_PAIRS = 2                     # the twin's default motor (Table I, 4 poles)


def make_twin() -> DriveTwin:
    twin = DriveTwin(seed=5)
    with twin.lock:
        twin.speed_rpm = SPEED_RPM
        twin.current_command_a = CURRENT_A
        twin.enable()
    return twin


def odd_history(twin: DriveTwin) -> None:
    """What a run leaves behind: time that is no whole number of PWM periods, PWM frequency
    changes, another operating point."""
    twin.advance(0.0100075, 1000.0, channels=())
    twin.set_injection(pwm_frequency_hz=40_000.0)
    twin.speed_rpm = -300.0
    twin.advance(0.0200031, 1000.0, channels=())
    twin.restore_defaults()
    twin.speed_rpm = SPEED_RPM
    # and stop 7.5 µs past a 20 kHz counter valley: the worst phase of an 8 kHz capture
    twin.advance(twin.next_carrier_valley_s() - twin.time_s + 7.5e-6, 1000.0, channels=())


def readings(twin: DriveTwin, *, pwm_synchronous: bool = True,
             rate_hz: float = RATE_HZ) -> list[float]:
    from ripple_hil_drivers.modbus_daq import ModbusDaq, ModbusTcpSettings
    from ripple_hil_drivers.simulated.modbus_daq_server import SimulatedDaq

    with SimulatedDaq(twin, pwm_synchronous=pwm_synchronous) as server, \
            ModbusDaq(ModbusTcpSettings(*server.address), timeout_s=2.0) as daq:
        capture = daq.capture(3960 / rate_hz, rate_hz, settle_s=0.05,
                              channels=("ia_a", "ib_a", "rotor_angle_mech_rad"))
    checks = current_channels(capture, CURRENT_A, POLE_PAIRS, 0.02)
    assert [c["name"] for c in checks] == ["current channel ia_a", "current channel ib_a"]
    return [c["measured"] for c in checks]


@pytest.fixture(scope="module")
def fresh_reading():
    return readings(make_twin())


def test_fresh_bench_reads_the_commanded_current(fresh_reading):
    assert fresh_reading == pytest.approx([CURRENT_A, CURRENT_A], abs=0.02)


def test_history_does_not_move_the_reading(fresh_reading):
    twin = make_twin()
    odd_history(twin)
    assert readings(twin) == pytest.approx(fresh_reading, abs=0.01)


def test_unsynchronised_sample_clock_shows_the_old_drift(fresh_reading):
    """The same history with the DAQ's first sample at the trigger instant (the old behaviour,
    and a software-triggered DAQ on a real bench): off by more than the self-check's noise,
    the failure mode this fix removes."""
    twin = make_twin()
    odd_history(twin)
    old = readings(twin, pwm_synchronous=False)
    assert min(abs(a - b) for a, b in zip(old, fresh_reading)) > 0.2


def test_an_incommensurate_rate_does_not_depend_on_the_phase():
    """What a real, software-triggered DAQ needs (its phase against the PWM is arbitrary): at
    7919 Hz the samples walk through the PWM period and the ripple averages out of the
    fundamental, whatever the phase the history left (the self-check's 8 kHz does not)."""
    twin = make_twin()
    odd_history(twin)
    assert readings(twin, pwm_synchronous=False, rate_hz=7919.0) == pytest.approx(
        [CURRENT_A, CURRENT_A], abs=0.02)


def test_large_accumulated_time_and_angle(fresh_reading):
    """A twin whose clock and rotor angle stand where 10^4 s at 500 rpm leave them (time,
    period start and angle shifted together: float precision of the absolute values)."""
    twin = make_twin()
    twin.advance(0.001, 1000.0, channels=())
    shift_s = 1.0e4
    with twin.lock:
        twin._state[L.S_TIME] += shift_s
        twin._state[L.S_THETA_M] += SPEED_RPM * 2 * math.pi / 60 * shift_s
        twin.time_s += shift_s
    assert readings(twin) == pytest.approx(fresh_reading, abs=0.01)


def test_next_carrier_valley_is_a_period_start():
    twin = make_twin()
    twin.advance(0.0003337, 1000.0, channels=())
    start = float(twin._state[L.S_TIME])
    valley = twin.next_carrier_valley_s()
    assert twin.time_s <= valley < twin.time_s + 1 / 20_000.0
    assert (valley - start) * 20_000.0 == pytest.approx(round((valley - start) * 20_000.0),
                                                         abs=1e-6)
    gap = twin.advance_to_carrier_valley()
    assert twin.time_s == valley and 0.0 < gap < 1 / 20_000.0
    assert twin.advance_to_carrier_valley() == 0.0
