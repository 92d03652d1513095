"""Helpers of the transport-fault tests: one small measurement point, and what every fault must
leave behind (a typed error naming instrument and step, a safe bench, an honest record)."""

from __future__ import annotations

import importlib.util
import shutil
from pathlib import Path

from ripple_hil_drivers.errors import InstrumentError
from hil.measurement import PointPlan
from hil.record import verify_captures

#: A short dc-offset point (3 electrical revolutions at 500 rpm: ~0.1 s simulated).
POINT = dict(source="dc_offset", injection={"ia_offset_a": 0.4, "ib_offset_a": -0.2},
             speed_rpm=500.0, current_a=20.0, revolutions=3)


def point(**overrides) -> PointPlan:
    return PointPlan(**(POINT | overrides))


def wrap(monkeypatch, obj, name: str, before=None, after=None, on_call: int = 1):
    """Replace ``obj.name`` so that on its ``on_call``-th call ``before()`` runs first and
    ``after(result)`` runs on its result (the moment a fault is injected)."""
    real = getattr(obj, name)
    calls = {"n": 0}

    def wrapped(*args, **kwargs):
        calls["n"] += 1
        hit = calls["n"] == on_call
        if hit and before is not None:
            before()
        result = real(*args, **kwargs)
        if hit and after is not None:
            after(result)
        return result

    monkeypatch.setattr(obj, name, wrapped)
    return calls


def assert_names(error: InstrumentError, instrument: str, *action_words: str) -> None:
    """The error is typed, says which instrument, and what it was doing."""
    assert isinstance(error, InstrumentError)
    assert error.instrument == instrument, error
    assert str(error).startswith(f"{instrument}: "), error
    for word in action_words:
        assert word in error.action, (word, error.action)


def assert_recorded_failure(bench, record, test_id: str, error: InstrumentError, *,
                            captured: bool) -> dict:
    """The failed point is in the record with its error, the guard's reason names the step,
    the raw data is kept if it was captured, and every capture file matches its hash."""
    entry = next(t for t in record.tests if t["test_id"] == test_id)
    assert entry["outcome"] == "error"
    assert type(error).__name__ in entry["error"] and error.instrument in entry["error"]
    if captured:
        assert entry["capture"] and entry["capture"]["sha256"], "raw data of the failed point lost"
        assert (record.path / entry["capture"]["file"]).is_file()
    else:
        assert entry["capture"] is None
    reasons = [r.reason for r in bench.safe_state_reports]
    assert any(reason.startswith(f"{test_id}: acquire") for reason in reasons), reasons
    assert verify_captures(record.path, record.data) == []
    assert record.data["pending_captures"] == []
    return entry


def record_factory():
    """tests/reports/record_factory.py, loaded by path (the test folders are not packages)."""
    path = Path(__file__).parents[1] / "reports" / "record_factory.py"
    spec = importlib.util.spec_from_file_location("reliability_record_factory", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def copy_record(small_record: Path, tmp_path: Path) -> Path:
    """A copy of a record folder that a test may damage."""
    folder = tmp_path / "record"
    shutil.copytree(small_record, folder)
    return folder
