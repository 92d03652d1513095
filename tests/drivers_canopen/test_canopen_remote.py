"""Cross-process transport: python-can-remote over TCP on 127.0.0.1 (free port), canopen on top."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
import time

import can
import pytest

from ripple_hil_drivers.canopen_transport import open_bus
from ripple_hil_drivers.cia402 import Cia402Drive
from ripple_hil_drivers.simulated.can_remote_server import serve_simulated_drive

pytestmark = [pytest.mark.integration, pytest.mark.timeout(60)]


@pytest.fixture
def remote_sim(twin):
    server = serve_simulated_drive(twin, node_id=5)
    yield server
    server.stop()


def test_driver_reaches_the_twin_through_the_tcp_bridge(remote_sim, twin):
    settings = remote_sim.client_settings
    assert settings.interface == "remote" and settings.channel.startswith("ws://127.0.0.1:")
    with Cia402Drive(settings, node_id=5) as drive:
        assert drive.identity()["product"] == 0x402
        drive.enable()
        assert twin.enabled
        drive.set_injection(ia_gain_error_pu=0.05, encoder_decimation=100, dead_time_s=1e-6)
        assert twin.injection.ia_gain_error_pu == pytest.approx(0.05)
        assert twin.injection.encoder_decimation == 100
        assert drive.injection()["dead_time_s"] == pytest.approx(1e-6)
        assert drive.actual()["state"] == "OPERATION ENABLED"
        drive.check_health()
        drive.disable()
        assert not twin.enabled


def test_periodic_frames_over_remote_can_change_data(remote_sim):
    # python-can-remote 0.3.0's own CyclicSendTask.modify_data raises TypeError; open_bus gives
    # the remote bus python-can's threaded periodic task, which canopen's heartbeat/SYNC need.
    with open_bus(remote_sim.client_settings) as client, \
            can.Bus(interface="virtual", channel=remote_sim.local_settings.channel) as local:
        task = client.send_periodic(can.Message(arbitration_id=0x7E0, data=[1], is_extended_id=False), 0.01)
        try:
            assert _recv_id(local, 0x7E0).data[0] == 1
            task.modify_data(can.Message(arbitration_id=0x7E0, data=[2], is_extended_id=False))
            deadline = time.monotonic() + 1.0
            while _recv_id(local, 0x7E0).data[0] != 2:
                assert time.monotonic() < deadline
        finally:
            task.stop()


def _recv_id(bus, can_id, timeout=1.0):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        msg = bus.recv(timeout=0.1)
        if msg is not None and msg.arbitration_id == can_id:
            return msg
    raise AssertionError(f"no frame 0x{can_id:X} within {timeout} s")


SERVER_SCRIPT = textwrap.dedent("""
    import json, sys
    from hil.sim import DriveTwin
    from ripple_hil_drivers.simulated.can_remote_server import serve_simulated_drive
    twin = DriveTwin(seed=0)
    server = serve_simulated_drive(twin, node_id=7)
    print(json.dumps(server.bench_table()), flush=True)
    sys.stdin.readline()          # the parent asks for the twin's injection, then closes stdin
    print(json.dumps({"enabled": twin.enabled,
                      "encoder_decimation": twin.injection.encoder_decimation,
                      "ia_offset_a": twin.injection.ia_offset_a}), flush=True)
    sys.stdin.read()
    server.stop()
""")


def test_second_process_uses_only_bench_file_settings():
    proc = subprocess.Popen([sys.executable, "-c", SERVER_SCRIPT], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, text=True)
    try:
        table = json.loads(proc.stdout.readline())
        from ripple_hil_drivers.canopen_transport import CanBusSettings
        settings = CanBusSettings(interface=table["interface"], channel=table["channel"],
                                  bitrate=table["bitrate"])
        with Cia402Drive(settings, node_id=table["node_id"]) as drive:
            drive.enable()
            drive.set_injection(encoder_decimation=100, ia_offset_a=0.75)
            assert drive.injection()["encoder_decimation"] == 100
            proc.stdin.write("report\n")
            proc.stdin.flush()
            seen_by_twin = json.loads(proc.stdout.readline())
            assert seen_by_twin == {"enabled": True, "encoder_decimation": 100, "ia_offset_a": 0.75}
            drive.disable()
    finally:
        proc.stdin.close()
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0


def _vcan0_available() -> bool:
    try:
        can.Bus(interface="socketcan", channel="vcan0").shutdown()
        return True
    except Exception:  # no SocketCAN on this machine (CI has none)
        return False


@pytest.mark.skipif(not _vcan0_available(), reason="no socketcan vcan0 on this machine")
def test_socketcan_vcan0_when_the_kernel_has_it(twin):
    from ripple_hil_drivers.canopen_transport import CanBusSettings
    from ripple_hil_drivers.simulated.drive_node import SimulatedDrive
    settings = CanBusSettings(interface="socketcan", channel="vcan0")
    with SimulatedDrive(twin, settings, node_id=5), Cia402Drive(settings, node_id=5) as drive:
        drive.enable()
        drive.set_injection(ib_gain_error_pu=-0.03)
        assert twin.enabled and twin.injection.ib_gain_error_pu == pytest.approx(-0.03)
        drive.disable()
