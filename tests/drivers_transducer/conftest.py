"""Fixtures of the transducer tests: the shared twin factory of the DAQ tests."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent.parent / "drivers_daq"))
from daq_twin import make_twin  # noqa: E402


@pytest.fixture
def twin(compiled_twin_engine):
    """The twin at its operating point, run 50 ms so the current loop has settled."""
    twin = make_twin()
    twin.advance(0.05, 1000.0)
    return twin


@pytest.fixture(scope="session")
def compiled_twin_engine():
    """Load the twin's compiled engine once (a throwaway twin), so no first reading waits."""
    make_twin(seed=1).advance(1e-3, 1000.0)
