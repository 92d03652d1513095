"""Dask LocalClusters on 127.0.0.1 shared by the campaign tests (one and two worker processes)."""

import pytest

from hil.campaign import dask_client


@pytest.fixture(scope="session")
def client_two():
    with dask_client(n_workers=2) as client:
        yield client


@pytest.fixture(scope="session")
def client_one():
    with dask_client(n_workers=1) as client:
        yield client
