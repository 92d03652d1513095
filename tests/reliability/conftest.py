"""Fixtures of the reliability suite: the integration suite's simulated bench and run record.

Reused, not copied: ``sim_bench`` (a freshly opened simulated bench over the real stacks:
CANopen on a virtual bus, Modbus TCP on 127.0.0.1, serial pty) and ``run_record`` (a run record
in a temporary folder) come from ``tests/integration/conftest.py``.
"""

from integration.conftest import run_record, sim_bench  # noqa: F401 - pytest fixtures
