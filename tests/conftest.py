"""Fixtures shared by the test folders: a simulated bench over the real stacks, a run record."""

import pytest

from hil.bench import Bench
from hil.config import default_sim_bench
from hil.record import RunRecord


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
