"""A real PostgreSQL for the results-database tests: initdb in a temporary folder, started as the
``postgres`` user when the tests run as root (CI), on 127.0.0.1 and a free port; stopped at the
end of the session. Skipped, with the reason, only when no PostgreSQL server binary exists."""

from __future__ import annotations

import time

import pytest

from hil.results.pg_server import PostgresServer, pg_bin


@pytest.fixture(autouse=True)
def results_database_off(monkeypatch):
    """Overrides tests/conftest.py's: these tests use the results database's real default rule."""
    monkeypatch.delenv("RIPPLE_HIL_RESULTS_DB", raising=False)


@pytest.fixture(scope="session")
def postgres_server():
    bin_dir = pg_bin()
    if bin_dir is None:
        pytest.skip("no PostgreSQL server binary (initdb/pg_ctl) on this machine")
    server = PostgresServer(bin_dir)
    try:
        yield server
    finally:
        server.close()


@pytest.fixture(scope="session")
def real_records(tmp_path_factory):
    """The records of a full default ``hil run`` and of a station run (``real_runs.py``)."""
    from real_runs import make_real_records

    return make_real_records(tmp_path_factory.mktemp("real-records"))


@pytest.fixture
def pg_url(postgres_server):
    """A fresh, empty database on the session's server."""
    from hil.results.db import dispose_all

    url = postgres_server.new_database()
    yield url
    dispose_all()


@pytest.fixture
def sqlite_url(tmp_path):
    from hil.results.db import dispose_all

    yield f"sqlite:///{tmp_path / 'results.sqlite'}"
    dispose_all()


def wait_for(predicate, timeout_s: float = 30.0, step_s: float = 0.05) -> bool:
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        if predicate():
            return True
        time.sleep(step_s)
    return predicate()
