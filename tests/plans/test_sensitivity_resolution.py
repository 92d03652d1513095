"""A sensitivity check (testplans/sensitivity.py) can fail: an interval wholly outside the band
is FAIL however wide its U (issue 21 item 5: 2.519 ± 0.324 against ±0.30 was skipped as "not
resolved"); only an interval that straddles a band edge AND is wider than the tolerance is "not
determinable here", which makes the source NOT DETERMINED, never PASS. Unit tests on a record
stub, then the statement derived from such a record."""

from __future__ import annotations

import pytest

from hil.outcome_kinds import NOT_DETERMINABLE, is_not_determinable
from ripple_hil_reports.statement import overall_statement, rejected_checks, source_states
from ripple_hil_testplans import sensitivity


class RecordStub:
    def __init__(self, tests):
        self.tests = tests
        self.sections = {}

    def set_section(self, name, data):
        self.sections[name] = data


EXPECTED_PU = (0.01, 0.02, 0.04)


def sweep(u_pu: float, scale: float = 1.0):
    return [{"test_id": f"t{i}", "source": "src", "injection": {"k": i}, "outcome": "passed",
             "measured": {"pk_pk_pu": scale * x},
             "verdict": {"decision": "pass", "predicted_pk_pk_pu": x,
                         "measured_pk_pk_pu": scale * x, "expanded_uncertainty_pu": u_pu}}
            for i, x in enumerate(EXPECTED_PU)]


@pytest.fixture(autouse=True)
def fresh_results(monkeypatch):
    monkeypatch.setattr(sensitivity, "_RESULTS", {})


def test_an_interval_wholly_outside_the_band_fails_however_wide():
    """The issue's case: a drive whose loop is half its stated bandwidth, slope 2.519 ± 0.324
    (k = 2) against 1 ± 0.30: U exceeds the tolerance, yet no value in the interval is inside
    the band, so the check rejects the drive (the old code skipped it as "not resolved")."""
    record = RecordStub(sweep(u_pu=0.007, scale=2.519))
    result = sensitivity.check_sensitivity(record, "src", 0.30)
    assert result["slope"] == pytest.approx(2.519, abs=1e-6)
    assert 2 * result["slope_u"] == pytest.approx(0.324, abs=0.01)
    assert 2 * result["slope_u"] > 0.30
    assert result["decision"] == "fail" and result["accepted"] is False
    assert rejected_checks(record.sections, "src") == ["sensitivity"]
    stated = source_states(record.sections | {"tests": record.tests})["src"]
    assert stated.state == "fail"


def test_a_wide_interval_straddling_a_band_edge_is_not_determinable():
    record = RecordStub(sweep(u_pu=0.05, scale=1.6))       # slope 1.6 ± 2.3 against 1 ± 0.3
    with pytest.raises(pytest.skip.Exception) as skipped:
        sensitivity.check_sensitivity(record, "src", 0.3)
    message = str(skipped.value.msg)
    assert is_not_determinable(message) and "straddles the band [0.70, 1.30]" in message
    section = record.sections["sensitivity"]["src"]
    assert section["decision"] == "not determinable" and section["accepted"] is None
    assert rejected_checks(record.sections, "src") == []
    # recorded as the plugin records such a skip: the source is NOT DETERMINED, never PASS
    tests = record.tests + [{"test_id": "sens", "source": "src", "outcome": NOT_DETERMINABLE,
                             "message": message}]
    stated = overall_statement(record.sections | {"status": "complete", "tests": tests}, [])
    assert stated.model == {"src": "not determined"}
    assert "src: NOT DETERMINED (3 pass, 1 not determined)" == stated.sources["src"].text
    assert stated.overall == "NOT STATED" and "not determined: src" in stated.reason


def test_the_same_slope_with_a_small_u_is_judged_and_rejected():
    record = RecordStub(sweep(u_pu=0.0005, scale=1.6))
    result = sensitivity.check_sensitivity(record, "src", 0.3)
    assert result["decision"] == "fail" and result["accepted"] is False
    assert rejected_checks(record.sections, "src") == ["sensitivity"]


def test_a_right_slope_passes_and_too_few_points_are_not_determinable():
    record = RecordStub(sweep(u_pu=0.001, scale=0.97))
    result = sensitivity.check_sensitivity(record, "src", 0.3)
    assert result["decision"] == "pass" and result["accepted"] is True
    with pytest.raises(pytest.skip.Exception) as skipped:
        sensitivity.check_sensitivity(RecordStub(sweep(u_pu=0.001)[:2]), "src", 0.3)
    assert is_not_determinable(str(skipped.value.msg))


def test_too_few_points_says_what_became_of_the_others():
    """1000 rpm / 30 A: two dead-time points were not determinable here (voltage headroom); the
    slope's reason said '(deselected or failed to measure)', which neither was."""
    record = RecordStub(sweep(u_pu=0.001)[:2])
    record.tests.append({"test_id": "t[4e-06]", "source": "src", "outcome": NOT_DETERMINABLE,
                         "kind": "other", "message": "not determinable here: headroom"})
    with pytest.raises(pytest.skip.Exception) as skipped:
        sensitivity.check_sensitivity(record, "src", 0.3)
    assert "(1 not determinable among the others)" in str(skipped.value.msg)
    with pytest.raises(pytest.skip.Exception) as skipped:
        sensitivity.check_sensitivity(RecordStub(sweep(u_pu=0.001)[:2]), "src", 0.3)
    assert "(the others deselected)" in str(skipped.value.msg)
