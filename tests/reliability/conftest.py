"""Fixtures of the reliability suite (the simulated bench and run record: tests/conftest.py)."""

from pathlib import Path

import pytest

from .faults import record_factory


@pytest.fixture(scope="module")
def small_record(tmp_path_factory) -> Path:
    """A small realistic run record (synthetic captures through the real analysis)."""
    return record_factory().write_record(tmp_path_factory.mktemp("rec"))
