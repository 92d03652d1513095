"""A sensitivity check whose U is wider than its tolerance is not judged (skipped, recorded as
"not resolved"), so it can neither reject a right drive nor accept a wrong one on noise; with a
small U the same slope is judged. Unit test on a record stub."""

from __future__ import annotations

import pytest

from ripple_hil_reports.statement import rejected_checks
from ripple_hil_testplans import sensitivity


class RecordStub:
    def __init__(self, tests):
        self.tests = tests
        self.sections = {}

    def set_section(self, name, data):
        self.sections[name] = data


def sweep(u_pu: float, scale: float = 1.0):
    return [{"test_id": f"t{i}", "source": "src", "injection": {"k": i},
             "measured": {"pk_pk_pu": scale * x},
             "verdict": {"predicted_pk_pk_pu": x, "measured_pk_pk_pu": scale * x,
                         "expanded_uncertainty_pu": u_pu}}
            for i, x in enumerate((0.01, 0.02, 0.04))]


@pytest.fixture(autouse=True)
def fresh_results(monkeypatch):
    monkeypatch.setattr(sensitivity, "_RESULTS", {})


def test_a_slope_with_u_wider_than_the_tolerance_is_not_judged():
    record = RecordStub(sweep(u_pu=0.05, scale=1.6))       # slope 1.6, U >> 0.3
    with pytest.raises(pytest.skip.Exception, match="exceeds the tolerance ±0.30, not judged"):
        sensitivity.check_sensitivity(record, "src", 0.3)
    section = record.sections["sensitivity"]["src"]
    assert section["decision"] == "not resolved" and section["accepted"] is None
    assert rejected_checks(record.sections, "src") == []


def test_the_same_slope_with_a_small_u_is_judged_and_rejected():
    record = RecordStub(sweep(u_pu=0.0005, scale=1.6))
    result = sensitivity.check_sensitivity(record, "src", 0.3)
    assert result["decision"] == "fail" and result["accepted"] is False
    assert rejected_checks(record.sections, "src") == ["sensitivity"]
