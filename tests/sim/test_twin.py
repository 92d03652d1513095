"""``hil.sim.DriveTwin``: the contract the simulated instruments use (COMMON.md)."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from hil.sim import DriveConfig, DriveTwin, Injection, simulate

CHANNELS = ("time_s", "rotor_angle_mech_rad", "encoder_counts", "ia_a", "ib_a", "ic_a",
            "torque_nm", "torque_em_nm", "dc_bus_v", "speed_rpm", "id_a", "iq_a")


def test_consecutive_advances_continue_one_trajectory():
    twin = DriveTwin(seed=3)
    first = twin.advance(0.0123, 10_000)
    second = twin.advance(0.0077, 10_000)
    whole = simulate(DriveConfig(), 0.02, 10_000)
    assert twin.time_s == pytest.approx(0.02)
    for name in ("ia_a", "torque_em_nm", "rotor_angle_mech_rad", "encoder_counts"):
        joined = np.concatenate([first[name], second[name]])
        np.testing.assert_allclose(joined, whole[name], atol=1e-9)
    np.testing.assert_allclose(np.diff(np.concatenate([first["time_s"], second["time_s"]])),
                               1e-4, atol=1e-12)
    assert set(CHANNELS) <= set(first)


def test_settle_is_run_but_not_returned():
    twin = DriveTwin()
    data = twin.advance(0.01, 10_000, settle_s=0.02)
    assert data["time_s"][0] == pytest.approx(0.02)
    assert len(data["time_s"]) == 100
    assert twin.time_s == pytest.approx(0.03)
    assert data["iq_a"].mean() == pytest.approx(10.0, rel=0.01)


def test_injections_and_commands_change_between_calls():
    twin = DriveTwin()
    twin.advance(0.02, 10_000)
    twin.set_injection(ia_offset_a=0.5, dead_time_s=1e-6)
    assert twin.injection == Injection(ia_offset_a=0.5, dead_time_s=1e-6)
    with pytest.raises(ValueError, match="ia_offset_a"):
        twin.set_injection(ib_offset_a=0.1, ia_offset_a=99.0)
    assert twin.injection.ib_offset_a == 0.0           # refused as a whole
    twin.current_command_a = 20.0
    twin.speed_rpm = -600.0
    with pytest.raises(ValueError, match="current_command_a"):
        twin.current_command_a = 150.0
    with pytest.raises(ValueError, match="speed_rpm"):
        twin.speed_rpm = 4000.0
    data = twin.advance(0.05, 10_000, settle_s=0.02)
    assert data["iq_a"].mean() == pytest.approx(20.0, rel=0.01)
    assert np.all(data["speed_rpm"] == -600.0)
    twin.restore_defaults()
    assert twin.injection == Injection()


def test_disable_stops_current_and_enable_restarts():
    twin = DriveTwin()
    twin.advance(0.02, 10_000)
    twin.disable()
    assert not twin.enabled
    off = twin.advance(0.01, 20_000)
    assert np.all(off["ia_a"][2:] == 0.0) and np.all(off["torque_em_nm"][2:] == 0.0)
    twin.enable()
    on = twin.advance(0.01, 20_000, settle_s=0.01)
    assert on["iq_a"].mean() == pytest.approx(10.0, rel=0.02)


def test_status_reports_latest_scalars():
    twin = DriveTwin()
    before = twin.status()
    assert before["time_s"] == 0.0 and before["torque_nm"] == 0.0
    data = twin.advance(0.02, 10_000)
    status = twin.status()
    assert set(status) == {"torque_nm", "torque_em_nm", "speed_rpm", "position_counts", "ia_a",
                           "ib_a", "dc_bus_v", "time_s"}
    assert status["torque_nm"] == data["torque_nm"][-1]
    assert status["position_counts"] == data["encoder_counts"][-1]
    assert status["time_s"] == pytest.approx(0.02)


def test_concurrent_callers_are_serialised():
    twin = DriveTwin()
    errors = []

    def capture():
        try:
            for _ in range(10):
                data = twin.advance(0.002, 10_000)
                assert np.all(np.diff(data["time_s"]) > 0)
        except Exception as exc:  # pragma: no cover - reported below
            errors.append(exc)

    def poke():
        try:
            for k in range(50):
                twin.set_injection(ia_offset_a=0.01 * (k % 5))
                twin.status()
        except Exception as exc:  # pragma: no cover
            errors.append(exc)

    threads = [threading.Thread(target=capture), threading.Thread(target=poke)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout=60)
    assert not errors
    assert twin.time_s == pytest.approx(0.02)
