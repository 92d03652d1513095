"""CANopen drive benchmark: SDO round trips per second and PDO rates, simulated drive.

Run:  .venv/bin/python benchmarks/canopen_bench.py [--seconds 1.0]

For each transport (python-can ``virtual`` in-process, and ``remote`` = python-can-remote over
TCP on 127.0.0.1) it prints:
  * SDO expedited uploads per second (driver ``sdo_read`` of 0x1000, one outstanding request),
  * verified injection writes per second (``set_injection`` = SDO download + SDO read-back),
  * TPDO frames per second received by the master with a 1 ms event timer (3 TPDOs configured),
  * RPDO frames per second sent back to back (controlword) and applied by the simulated drive,
    and the fraction lost (0 expected: the virtual bus and the websocket queue frames).
The TPDO rate is bounded by the simulated node's scheduler tick (1 ms at a 1 ms event timer).
The figures depend on machine load (the CI machine is shared); they are not pass/fail targets.
"""

from __future__ import annotations

import argparse
import time
import uuid

from ripple_hil_drivers.canopen_transport import CanBusSettings
from ripple_hil_drivers.cia402 import Cia402Drive
from ripple_hil_drivers.simulated.can_remote_server import RemoteSimulatedDrive
from ripple_hil_drivers.simulated.drive_node import SimulatedDrive
from hil.sim import DriveTwin


def rate(func, seconds: float) -> float:
    count, start = 0, time.perf_counter()
    while (elapsed := time.perf_counter() - start) < seconds:
        func()
        count += 1
    return count / elapsed


def measure(drive: Cia402Drive, sim: SimulatedDrive, seconds: float) -> dict:
    figures = {"sdo_uploads_per_s": rate(lambda: drive.sdo_read(0x1000), seconds)}
    toggle = iter(range(10**9))
    figures["verified_injection_writes_per_s"] = rate(
        lambda: drive.set_injection(ia_offset_a=(next(toggle) % 2) * 0.5), seconds)
    drive.restore_injection_defaults()

    received = []
    for number in (1, 2, 3):
        drive.node.tpdo[number].add_callback(lambda pdo_map: received.append(1))
    time.sleep(seconds)
    figures["tpdo_frames_per_s"] = len(received) / seconds

    applied_before = sim.pdo.rpdos_applied
    start = time.perf_counter()
    sent = 0
    while time.perf_counter() - start < seconds:
        drive._send_controlword(0x00, "benchmark RPDO")
        sent += 1
    send_s = time.perf_counter() - start
    last, deadline = -1, time.monotonic() + 5.0  # let the node drain its receive queue
    while sim.pdo.rpdos_applied != last and time.monotonic() < deadline:
        last = sim.pdo.rpdos_applied
        time.sleep(0.1)
    applied = sim.pdo.rpdos_applied - applied_before
    figures["rpdo_frames_sent_per_s"] = sent / send_s
    figures["rpdo_frames_applied_per_s"] = applied / (time.perf_counter() - start - 0.1)
    figures["rpdo_frames_lost_fraction"] = 1 - applied / sent
    return figures


def run_virtual(seconds: float) -> dict:
    settings = CanBusSettings(interface="virtual", channel=f"bench-{uuid.uuid4().hex[:8]}")
    with SimulatedDrive(DriveTwin(seed=0), settings, node_id=5) as sim, \
            Cia402Drive(settings, node_id=5, tpdo_event_timer_ms=1) as drive:
        return measure(drive, sim, seconds)


def run_remote(seconds: float) -> dict:
    with RemoteSimulatedDrive(DriveTwin(seed=0), node_id=5) as server, \
            Cia402Drive(server.client_settings, node_id=5, tpdo_event_timer_ms=1) as drive:
        return measure(drive, server.drive, seconds)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=1.0, help="duration of each measurement")
    args = parser.parse_args()
    for name, runner in (("virtual (in-process)", run_virtual), ("remote (TCP 127.0.0.1)", run_remote)):
        figures = runner(args.seconds)
        print(f"{name}:")
        for key, value in figures.items():
            print(f"  {key:34s} {value:10.2f}")


if __name__ == "__main__":
    main()
