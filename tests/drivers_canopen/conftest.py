"""Fixtures for the CANopen drive tests: a twin, a simulated drive node, a connected driver."""

from __future__ import annotations

import itertools
import os

import pytest

from ripple_hil_drivers.canopen_transport import CanBusSettings

from hil.sim import DriveTwin  # integration tests use the real digital twin

_channels = itertools.count()


def unique_virtual_settings() -> CanBusSettings:
    """A python-can virtual channel no other test uses (virtual buses are per-process)."""
    return CanBusSettings(interface="virtual", channel=f"canopen-test-{os.getpid()}-{next(_channels)}")


@pytest.fixture
def twin():
    return DriveTwin(seed=0)


@pytest.fixture
def bus_settings() -> CanBusSettings:
    return unique_virtual_settings()


@pytest.fixture
def sim_drive(twin, bus_settings):
    from ripple_hil_drivers.simulated.drive_node import SimulatedDrive
    sim = SimulatedDrive(twin, bus_settings, node_id=5, serial_number=0x1234)
    sim.start()
    yield sim
    sim.stop()


@pytest.fixture
def drive(sim_drive, bus_settings):
    from ripple_hil_drivers.cia402 import Cia402Drive
    drv = Cia402Drive(bus_settings, node_id=5, sdo_timeout_s=0.5, heartbeat_timeout_s=0.5)
    drv.connect()
    yield drv
    drv.close()
