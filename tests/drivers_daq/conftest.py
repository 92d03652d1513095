"""Fixtures of the DAQ tests: a drive twin at an operating point, the simulated DAQ, the driver."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))
from daq_twin import make_twin  # noqa: E402


@pytest.fixture
def twin():
    return make_twin()


@pytest.fixture
def daq_server(twin):
    from ripple_hil_drivers.simulated.modbus_daq_server import SimulatedDaq
    with SimulatedDaq(twin) as server:
        yield server


@pytest.fixture
def daq(daq_server):
    from ripple_hil_drivers.modbus_daq import ModbusDaq, ModbusTcpSettings
    with ModbusDaq(ModbusTcpSettings(*daq_server.address), timeout_s=1.0) as client:
        yield client


@pytest.fixture(scope="session", autouse=True)
def compiled_twin_engine():
    """Load the twin's compiled engine once (a throwaway twin), so no first capture waits."""
    make_twin(seed=1).advance(1e-3, 1000.0)
