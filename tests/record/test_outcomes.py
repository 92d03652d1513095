"""pytest's phase reports → the record's outcome, phase and message (fixtures.outcomes), on real
reports of a throw-away test file run in-process (the ripple-hil plugin is not involved)."""

from __future__ import annotations

import pytest

from ripple_hil_fixtures.outcomes import merged_outcome, outcome_of

pytest_plugins = ["pytester"]

CASES = '''
import pytest

@pytest.fixture
def broken():
    raise RuntimeError("fixture broke")

@pytest.fixture
def bad_teardown():
    yield
    raise RuntimeError("teardown broke")

def test_passes():
    pass

def test_fails():
    assert 1 == 2, "user limit exceeded"

def test_setup_error(broken):
    pass

def test_teardown_error(bad_teardown):
    pass

def test_skipped():
    pytest.skip("no Hall sensors fitted")

@pytest.mark.xfail(reason="known drive bug")
def test_xfailed():
    assert False

@pytest.mark.xfail(reason="known drive bug", strict=True)
def test_xpassed_strict():
    pass

@pytest.mark.xfail(reason="known drive bug")
def test_xpassed():
    pass
'''


def test_every_pytest_outcome_maps_to_the_record(pytester):
    pytester.makepyfile(test_cases=CASES)
    run = pytester.inline_run("-p", "no:ripple_hil", "-p", "no:cacheprovider")
    reports: dict[str, list] = {}
    for report in run.getreports("pytest_runtest_logreport"):
        reports.setdefault(report.nodeid.split("::")[-1], []).append(report)
    got = {name: outcome_of(phases) for name, phases in reports.items()}
    assert got["test_passes"] == ("passed", "call", None)
    assert got["test_fails"][:2] == ("failed", "call")
    assert "user limit exceeded" in got["test_fails"][2]
    assert got["test_setup_error"][:2] == ("error", "setup")
    assert "fixture broke" in got["test_setup_error"][2]
    assert got["test_teardown_error"][:2] == ("error", "teardown")
    assert "teardown broke" in got["test_teardown_error"][2]
    assert got["test_skipped"] == ("skipped", "call", "no Hall sensors fitted")
    assert got["test_xfailed"][:2] == ("xfailed", "call")
    assert "known drive bug" in got["test_xfailed"][2]
    assert got["test_xpassed_strict"][:2] == ("failed", "call")      # pytest: failed
    assert got["test_xpassed"][:2] == ("xpassed", "call")


@pytest.mark.parametrize("recorded, reported, expected", [
    ("passed", "failed", "failed"),          # a user assertion after measure()
    ("error", "failed", "failed"),           # the measurement raised: pytest says failed
    ("failed", "passed", "passed"),          # the plan accepted a failed model verdict
    (None, "skipped", "skipped"),
])
def test_merged_outcome(recorded, reported, expected):
    assert merged_outcome(recorded, reported) == expected
