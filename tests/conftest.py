"""Fixtures shared by the test folders: a simulated bench over the real stacks, a run record."""

import pytest

from hil.bench import Bench
from hil.config import default_sim_bench
from hil.record import RunRecord


@pytest.fixture(autouse=True)
def results_database_off(monkeypatch):
    """Runs that tests make index nothing (``RIPPLE_HIL_RESULTS_DB=off``, inherited by their
    subprocesses): the results database is a sink with tests of its own (``tests/results``,
    which override this fixture), and a ``results.sqlite`` beside every test's records would
    only be noise in folders the tests list."""
    monkeypatch.setenv("RIPPLE_HIL_RESULTS_DB", "off")


@pytest.fixture
def sim_bench():
    """A freshly opened simulated bench (CANopen on a virtual bus, Modbus TCP, serial pty)."""
    bench = Bench.open(default_sim_bench(), seed=3)
    yield bench
    bench.close()


@pytest.fixture
def run_record(tmp_path, sim_bench):
    record = RunRecord.create(tmp_path, sim_bench.config, sim_bench.identities())
    yield record
    if record.status == "running":
        record.finish("complete")
