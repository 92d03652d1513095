"""Fixtures of the DAQ tests: a drive twin at an operating point, the simulated DAQ, the driver."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))
from daq_fake_twin import FakeTwin  # noqa: E402

SPEED_RPM = 1000.0
CURRENT_A = 10.0


def make_twin(seed: int = 0):
    """The real ``hil.sim.DriveTwin`` once it exists, else the interface-compatible fake."""
    if importlib.util.find_spec("hil.sim.twin") is not None:
        from hil.sim import DriveTwin
        twin = DriveTwin(seed=seed)
    else:
        twin = FakeTwin(seed=seed)
    with twin.lock:
        twin.speed_rpm = SPEED_RPM
        twin.current_command_a = CURRENT_A
        twin.enable()
    return twin


@pytest.fixture
def twin():
    return make_twin()


@pytest.fixture
def daq_server(twin):
    from drivers.simulated.modbus_daq_server import SimulatedDaq
    with SimulatedDaq(twin) as server:
        yield server


@pytest.fixture
def daq(daq_server):
    from drivers.modbus_daq import ModbusDaq, ModbusTcpSettings
    with ModbusDaq(ModbusTcpSettings(*daq_server.address), timeout_s=1.0) as client:
        yield client
