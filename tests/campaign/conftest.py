"""Dask LocalClusters on 127.0.0.1 shared by the campaign tests (one and two worker processes).

Each is shared by the tests of one module and closed after them (~3 s to start): an idle
LocalCluster's processes keep ~0.1 core busy (heartbeats, memory monitors), which a
session-long cluster took from the rest of its xdist worker's tests for the whole session."""

import pytest

from hil.campaign import dask_client


@pytest.fixture(scope="module")
def client_two():
    with dask_client(n_workers=2) as client:
        yield client


@pytest.fixture(scope="module")
def client_one():
    with dask_client(n_workers=1) as client:
        yield client


@pytest.fixture(scope="session")
def twin_compiled():
    """Compile (or load) the twin and the analysis here first, so the workers load numba's
    on-disk cache instead of compiling both twice in parallel on a cold cache."""
    from hil.campaign.twin import TwinSettings, twin_ripple_pu
    from hil.sim import DriveConfig

    twin_ripple_pu([DriveConfig(speed_rpm=3000)], TwinSettings(revolutions=1, settle_s=0.0))
