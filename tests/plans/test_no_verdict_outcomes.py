"""Tests that judge nothing are not passes (issue 21 item 6, design.md §9): a skip marked
``not_determinable(reason)`` is recorded "not determinable" with its reason; a test whose
``measure()`` judged nothing (no model rule, no requirement, no self-check) stays "measured, no
verdict" when pytest passes it, and "failed" when it fails. The diagnosis plan's fit test can
fail: a controller parameter it cannot state fails it."""

from __future__ import annotations

import math
from types import SimpleNamespace

import pytest

from hil.outcome_kinds import MEASURED, NOT_DETERMINABLE
from ripple_hil_fixtures.outcomes import merged_outcome, outcome_of

pytest_plugins = ["pytester"]

CASES = '''
import pytest
from hil.outcome_kinds import not_determinable

def test_not_determinable_in_call():
    pytest.skip(not_determinable("12 bit at 250 rpm: the ripple is below the bench's floor"))

@pytest.fixture
def refused():
    pytest.skip(not_determinable("capture rate too low for 40 kHz"))

def test_not_determinable_in_setup(refused):
    pass

def test_plain_skip():
    pytest.skip("needs a real bench")
'''


def test_a_not_determinable_skip_is_recorded_as_such_with_its_reason(pytester):
    pytester.makepyfile(test_cases=CASES)
    run = pytester.inline_run("-p", "no:ripple_hil", "-p", "no:cacheprovider")
    reports: dict[str, list] = {}
    for report in run.getreports("pytest_runtest_logreport"):
        reports.setdefault(report.nodeid.split("::")[-1], []).append(report)
    got = {name: outcome_of(phases) for name, phases in reports.items()}
    outcome, phase, message = got["test_not_determinable_in_call"]
    assert (outcome, phase) == (NOT_DETERMINABLE, "call")
    assert message == ("not determinable here: 12 bit at 250 rpm: the ripple is below the "
                       "bench's floor")
    assert got["test_not_determinable_in_setup"][:2] == (NOT_DETERMINABLE, "setup")
    assert got["test_plain_skip"] == ("skipped", "call", "needs a real bench")


@pytest.mark.parametrize("recorded, reported, expected", [
    (MEASURED, "passed", MEASURED),          # nothing judged it: never a pass
    (MEASURED, "failed", "failed"),          # a user assertion after the measurement failed
    ("passed", "passed", "passed"),
    (None, "passed", "passed"),              # a test without measure(): its own asserts
])
def test_a_measured_point_stays_measured_unless_it_fails(recorded, reported, expected):
    assert merged_outcome(recorded, reported) == expected


def estimate(name, value=0.1, u=0.01, identifiable=True):
    return SimpleNamespace(name=name, estimate=value, standard_uncertainty=u,
                           identifiable=identifiable, unit="A")


def test_the_diagnosis_fails_when_it_cannot_state_a_controller_parameter():
    from ripple_hil_testplans.test_diagnosis import unstated_parameters

    good = [estimate("ia_offset_a"), estimate("ib_offset_a"), estimate("gain_k_diff"),
            estimate("dead_time_us"), estimate("cogging_m12_re_nm", u=math.nan)]
    assert unstated_parameters(SimpleNamespace(parameters=good)) == []
    bad = [estimate("ia_offset_a", u=math.nan), estimate("ib_offset_a", identifiable=False),
           estimate("dead_time_us", value=math.inf), estimate("gain_k_diff", u=0.0)]
    problems = unstated_parameters(SimpleNamespace(parameters=bad))
    assert [p.split(":")[0] for p in problems] == ["ia_offset_a", "ib_offset_a", "gain_k_diff",
                                                   "dead_time_us"]
    assert unstated_parameters(SimpleNamespace(parameters=good[1:])) == [
        "ia_offset_a: not fitted"]


def test_the_record_accepts_the_shared_outcome_words():
    """``hil.measurement`` records "measured, no verdict" and the plugin "not determinable":
    the record's outcome list must hold both (``hil/record.py`` OUTCOMES += the two words of
    ``hil.outcome_kinds``), or every point that judges nothing errors when it is recorded."""
    import hil.record

    missing = {MEASURED, NOT_DETERMINABLE} - set(hil.record.OUTCOMES)
    assert not missing, (f"hil.record.OUTCOMES lacks {sorted(missing)}: add "
                         f"hil.outcome_kinds.NOT_DETERMINABLE and MEASURED to it")
