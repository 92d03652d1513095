"""Run records: schema, atomic test-by-test writing, crash safety, capture hashes, safe names."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from hil.capture import Capture
from hil.config import default_sim_bench
from hil.errors import HilError, InputError
from hil.record import (FORMAT, JOURNAL_FILE, SEAL_FILE, RecordWriteError, RunRecord,
                        load_record, safe_test_name, to_jsonable, verify_captures, verify_record)

IDENTITIES = [{"role": "drive", "identity": {"vendor_id": 0x1234, "product_code": np.uint32(7),
                                             "serial_number": "SIM-DRIVE-1",
                                             "firmware": "1.2.3"}},
              {"role": "daq", "model": "sim DAQ", "serial_number": "SIM-DAQ-0001"}]


def small_capture(n: int = 200, rate_hz: float = 10_000.0) -> Capture:
    t = np.arange(n) / rate_hz
    return Capture({"time_s": t, "torque_nm": 1.0 + 0.02 * np.sin(2 * np.pi * 50 * t)},
                   meta={"sample_rate_hz": rate_hz, "pole_pairs": 2, "source": "simulation"})


@pytest.fixture
def record(tmp_path: Path) -> RunRecord:
    return RunRecord.create(tmp_path, default_sim_bench(), IDENTITIES,
                            decision_rule={"rule": "guarded acceptance", "guard_band_pu": 0.1})


def test_create_writes_the_schema_before_any_test(record: RunRecord):
    data = json.loads((record.path / "record.json").read_text())
    assert data["format"] == FORMAT and data["status"] == "running"
    assert data["finished_utc"] is None and data["tests"] == []
    assert record.path.name == data["record_id"]
    assert data["created_utc"].endswith("Z")
    software = data["software"]
    assert software["version"] and software["python"].startswith("3.")
    assert set(software["packages"]) >= {"numpy", "scipy", "canopen", "python-can", "pymodbus",
                                         "pyserial"}
    assert software["packages"]["numpy"] == np.__version__
    assert len(software["git_sha"] or "x" * 40) == 40
    bench = data["bench"]
    assert bench["simulated"] is True and len(bench["sha256"]) == 64
    assert bench["loaded"]["motor"]["pole_count"] == 4
    roles = {row["role"]: row for row in data["instruments"]}
    assert roles["drive"]["identity"]["product_code"] == 7
    assert roles["drive"]["problems"] == []
    assert roles["daq"]["identity"] == {"model": "sim DAQ", "serial_number": "SIM-DAQ-0001"}
    assert roles["torque"]["accuracy_class"] == "0.1 % FS" and roles["torque"]["identity"] == {}
    assert data["decision_rule"]["guard_band_pu"] == 0.1


def test_record_ids_are_unique(tmp_path: Path):
    ids = {RunRecord.create(tmp_path, default_sim_bench(), []).record_id for _ in range(5)}
    assert len(ids) == 5


def test_serial_number_mismatch_is_flagged(tmp_path: Path):
    rec = RunRecord.create(tmp_path, default_sim_bench(),
                           [{"role": "torque", "serial_number": "OTHER-1"},
                            {"role": "thermometer", "model": "PT100"}])
    rows = {row["role"]: row for row in rec.data["instruments"]}
    assert "differs from the bench file's 'SIM-TQ-0001'" in rows["torque"]["problems"][0]
    assert rows["thermometer"]["problems"] == ["not described in the bench file "
                                               "(no calibration data)"]


def test_capture_first_then_entry_test_by_test(record: RunRecord):
    capture = small_capture()
    info = record.save_capture("testplans/test_offset.py::test_offset[0.01]", capture)
    on_disk = load_record(record.path)
    assert on_disk["pending_captures"][0]["sha256"] == info["sha256"]   # hash kept pre-analysis
    assert info["n_samples"] == 200 and info["sample_rate_hz"] == 10_000.0
    assert info["file"].startswith("captures/") and (record.path / info["file"]).is_file()
    stored = record.add_test({
        "test_id": "testplans/test_offset.py::test_offset[0.01]", "outcome": "passed",
        "injection": {"ia_offset_a": np.float64(0.2)},
        "measured": {"ripple_pp_pu": np.float32(0.04), "orders": np.arange(3),
                     "bad": float("nan")},
        "verdict": {"decision": "pass"}})
    assert stored["capture"] == info
    data = load_record(record.path)
    assert data["pending_captures"] == []
    test = data["tests"][0]
    assert test["measured"] == {"ripple_pp_pu": pytest.approx(0.04), "orders": [0, 1, 2],
                                "bad": None}
    assert test["prediction"] is None and test["notes"] == [] and test["finished_utc"]
    record.add_test({"test_id": "second", "outcome": "skipped", "notes": ["no dyno"]})
    assert [t["test_id"] for t in load_record(record.path)["tests"]] == [
        "testplans/test_offset.py::test_offset[0.01]", "second"]
    assert record.verify_captures() == []
    record.finish("complete")
    data = load_record(record.path)
    assert data["status"] == "complete" and data["finished_utc"]
    with pytest.raises(HilError, match="already finished"):
        record.add_test({"test_id": "late", "outcome": "passed"})
    reopened = RunRecord.open(record.path / "record.json")
    assert reopened.status == "complete" and len(reopened.tests) == 2


def test_entry_checks(record: RunRecord):
    with pytest.raises(InputError, match="outcome = 'ok'; allowed: passed, failed, error"):
        record.add_test({"test_id": "a", "outcome": "ok"})
    with pytest.raises(InputError, match=r"unknown test entry key\(s\) \['mesured'\]"):
        record.add_test({"test_id": "a", "outcome": "passed", "mesured": {}})
    record.add_test({"test_id": "a", "outcome": "passed"})
    with pytest.raises(HilError, match="already recorded"):
        record.add_test({"test_id": "a", "outcome": "passed"})
    with pytest.raises(HilError, match="agreed before the first test"):
        record.set_decision_rule({"rule": "changed after measuring"})
    record.save_capture("b", small_capture())
    with pytest.raises(HilError, match="already exists"):
        record.save_capture("b", small_capture())
    with pytest.raises(InputError, match="cannot store a object"):
        record.add_test({"test_id": "c", "outcome": "passed", "measured": {"x": object()}})
    with pytest.raises(InputError, match="finish status = 'done'"):
        record.finish("done")


@pytest.mark.parametrize("test_id", ["../../etc/passwd", "/abs/path", "..", "a/../../b",
                                     "x\\..\\y", "C:\\evil", ".hidden", "tp::t[a/b]", "ü ñ"])
def test_test_ids_cannot_escape_the_record(record: RunRecord, test_id: str):
    info = record.save_capture(test_id, small_capture(10))
    target = (record.path / info["file"]).resolve()
    assert target.parent == (record.path / "captures").resolve()
    assert not target.name.startswith(".")
    assert target.is_file()


def test_safe_names_keep_distinct_ids_distinct():
    assert safe_test_name("plain_id-1.x") == "plain_id-1.x"
    assert safe_test_name("a/b") != safe_test_name("a_b")
    assert safe_test_name("t[1/2]") != safe_test_name("t[1_2]")
    with pytest.raises(InputError):
        safe_test_name("")


def test_a_capture_written_in_the_background_is_the_capture_as_taken(record: RunRecord):
    capture = small_capture()
    taken = capture.channels["torque_nm"].copy()
    saving = record.save_capture_later("point", capture)
    capture.channels["torque_nm"] *= 2.0            # what the point does afterwards
    capture.meta["sample_rate_hz"] = 1.0
    with pytest.raises(HilError, match="already exists"):
        record.save_capture_later("point", small_capture())
    stored = record.add_test({"test_id": "point", "outcome": "passed"})   # waits for it
    assert stored["capture"] == saving.result() == record.capture_written("point")
    on_disk = Capture.load(record.path / stored["capture"]["file"])
    np.testing.assert_array_equal(on_disk["torque_nm"], taken)
    assert on_disk.meta["sample_rate_hz"] == 10_000.0
    events = [json.loads(line)["event"] for line in
              (record.path / JOURNAL_FILE).read_text().splitlines()]
    assert events.index("capture") < events.index("test")
    record.save_capture_later("characterisation", small_capture())   # no entry: finish waits
    record.finish("complete")
    data = load_record(record.path)
    assert [p["test_id"] for p in data["pending_captures"]] == ["characterisation"]
    assert verify_captures(record.path, data) == []


def test_a_background_write_that_fails_is_raised_to_the_point(record: RunRecord, monkeypatch):
    def full_disk(self, path):
        raise OSError(28, "No space left on device", str(path))

    monkeypatch.setattr(Capture, "save", full_disk)
    saving = record.save_capture_later("point", small_capture())
    with pytest.raises(RecordWriteError, match="ENOSPC|No space"):
        record.capture_written("point")
    assert isinstance(saving.exception(), RecordWriteError)
    assert isinstance(record.write_error, RecordWriteError)
    stored = record.add_test({"test_id": "point", "outcome": "error"})    # still recorded
    assert stored["capture"] is None


def test_verify_captures_finds_altered_missing_and_escaping_files(record: RunRecord):
    first = record.save_capture("one", small_capture())
    record.add_test({"test_id": "one", "outcome": "passed"})
    second = record.save_capture("two", small_capture())
    record.add_test({"test_id": "two", "outcome": "failed"})
    record.add_test({"test_id": "three", "outcome": "error",
                     "capture": {"file": "../record.json", "sha256": "0" * 64}})
    path = record.path / first["file"]
    raw = bytearray(path.read_bytes())
    raw[len(raw) // 2] ^= 0xFF
    path.write_bytes(bytes(raw))
    (record.path / second["file"]).unlink()
    problems = verify_captures(record.path)
    assert len(problems) == 3
    assert "'one'" in problems[0] and "SHA-256" in problems[0]
    assert "'two'" in problems[1] and "missing" in problems[1]
    assert "'three'" in problems[2] and "outside captures/" in problems[2]


def test_load_record_rejects_foreign_files(tmp_path: Path):
    with pytest.raises(InputError, match="cannot read record.json"):
        load_record(tmp_path)
    (tmp_path / "record.json").write_text("{not json")
    with pytest.raises(InputError, match="not valid JSON"):
        load_record(tmp_path)
    (tmp_path / "record.json").write_text(json.dumps({"format": "other/1"}))
    with pytest.raises(InputError, match="format = 'other/1'; expected 'ripple-hil-record/2'"):
        load_record(tmp_path)


def test_context_manager_sets_the_final_status(tmp_path: Path):
    with RunRecord.create(tmp_path, default_sim_bench(), [], name="ok") as rec:
        rec.add_test({"test_id": "t", "outcome": "passed"})
    assert load_record(rec.path)["status"] == "complete"
    with pytest.raises(KeyboardInterrupt):
        with RunRecord.create(tmp_path, default_sim_bench(), [], name="ctrl-c") as rec:
            raise KeyboardInterrupt
    assert load_record(rec.path)["status"] == "interrupted"
    with pytest.raises(RuntimeError):
        with RunRecord.create(tmp_path, default_sim_bench(), [], name="boom") as rec:
            raise RuntimeError("instrument fell off")
    assert load_record(rec.path)["status"] == "failed"
    with pytest.raises(InputError, match="already holds a record.json"):
        RunRecord.create(tmp_path, default_sim_bench(), [], name="ok")


def test_a_killed_run_keeps_every_finished_test_and_the_failed_capture(tmp_path: Path):
    """SIGKILL a writer mid-run: the record is valid JSON with every test it had finished."""
    script = textwrap.dedent(f"""
        import sys, time, numpy as np
        from hil.capture import Capture
        from hil.config import default_sim_bench
        from hil.record import RunRecord
        rec = RunRecord.create({str(tmp_path)!r}, default_sim_bench(), [], name="run")
        for i in range(3):
            t = np.arange(100) / 1e4
            rec.save_capture(f"t{{i}}", Capture({{"time_s": t, "torque_nm": np.ones(100)}}))
            rec.add_test({{"test_id": f"t{{i}}", "outcome": "passed"}})
        rec.save_capture("t3", Capture({{"time_s": np.arange(10.0)}}))
        print("ready", flush=True)
        time.sleep(60)
    """)
    proc = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == "ready"
    finally:
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=10)
    data = load_record(tmp_path / "run")
    assert data["status"] == "running"                       # never finished: partial
    assert [t["test_id"] for t in data["tests"]] == ["t0", "t1", "t2"]
    assert [p["test_id"] for p in data["pending_captures"]] == ["t3"]
    assert verify_captures(tmp_path / "run") == []
    assert not list((tmp_path / "run").rglob("*.tmp"))


def test_to_jsonable_handles_result_objects():
    class Result:
        def to_dict(self):
            return {"amplitude_nm": np.array([0.1, np.inf])}
    assert to_jsonable({"r": Result(), "p": Path("/x"), "c": 1 + 2j}) == {
        "r": {"amplitude_nm": [0.1, None]}, "p": "/x", "c": {"re": 1.0, "im": 2.0}}


def test_writes_are_appends_and_the_summary_is_written_once(record: RunRecord):
    """O(new data): record.json keeps its header while tests are added; each event is one
    journal line; finish writes record.json once, seals it and removes the journal."""
    header = (record.path / "record.json").read_bytes()
    journal = record.path / JOURNAL_FILE
    sizes = []
    for i in range(4):
        record.add_test({"test_id": f"t{i}", "outcome": "passed", "measured": {"x": [0.5] * 50}})
        sizes.append(journal.stat().st_size)
    assert (record.path / "record.json").read_bytes() == header
    steps = np.diff(sizes)
    assert np.all(np.abs(steps - steps[0]) <= 2)               # constant per test, not growing
    assert len(journal.read_text().splitlines()) == 4
    assert [t["test_id"] for t in load_record(record.path)["tests"]] == ["t0", "t1", "t2", "t3"]
    record.finish("complete")
    assert not journal.exists() and (record.path / SEAL_FILE).is_file()
    assert json.loads((record.path / "record.json").read_text())["tests"][3]["measured"]["x"][0] \
        == 0.5
    assert verify_record(record.path) == []


def test_every_pytest_outcome_and_later_updates(record: RunRecord):
    for outcome in ("passed", "failed", "error", "skipped", "xfailed", "xpassed", "not run"):
        record.add_test({"test_id": outcome, "outcome": outcome, "phase": "call",
                         "kind": "other", "message": f"{outcome} because"})
    record.update_test("passed", outcome="failed", message="AssertionError: user limit")
    with pytest.raises(InputError, match="unknown updatable test field key"):
        record.update_test("passed", measured={})
    with pytest.raises(InputError, match="phase = 'run'"):
        record.update_test("passed", phase="run")
    with pytest.raises(HilError, match="not recorded"):
        record.update_test("ghost", outcome="failed")
    data = load_record(record.path)
    entry = next(t for t in data["tests"] if t["test_id"] == "passed")
    assert entry["outcome"] == "failed" and entry["message"] == "AssertionError: user limit"
    assert [t["outcome"] for t in data["tests"]][1:] == ["failed", "error", "skipped", "xfailed",
                                                         "xpassed", "not run"]


def test_sections_are_stored_and_reserved_names_refused(record: RunRecord):
    record.set_section("diagnosis", {"ranked": [{"source": "dc_offset", "share": np.float64(0.7)}]})
    record.set_section("run", {"selection": {"deselected": 3}})
    record.set_section("run", {"selection": {"deselected": 2}})
    for bad in ("tests", "status", "Bad-Name"):
        with pytest.raises(InputError, match="section name"):
            record.set_section(bad, {})
    data = load_record(record.path)
    assert data["diagnosis"]["ranked"][0]["share"] == 0.7
    assert data["run"] == {"selection": {"deselected": 2}}
    record.finish("aborted")
    assert load_record(record.path)["run"]["selection"]["deselected"] == 2


def test_a_changed_record_json_breaks_its_seal(record: RunRecord):
    record.add_test({"test_id": "t", "outcome": "failed"})
    record.finish("complete")
    path = record.path / "record.json"
    path.write_text(path.read_text().replace('"failed"', '"passed"'))
    problems = verify_record(record.path)
    assert len(problems) == 2 and "changed after the run finished" in problems[0]
    assert "the signature does not match record.json" in problems[1]
    (record.path / SEAL_FILE).unlink()
    assert "not sealed" in verify_record(record.path)[0]


def test_a_torn_last_journal_line_is_dropped(record: RunRecord):
    record.add_test({"test_id": "kept", "outcome": "passed"})
    with open(record.path / JOURNAL_FILE, "a") as handle:
        handle.write('{"event": "test", "entry": {"test_id": "half')
    assert [t["test_id"] for t in load_record(record.path)["tests"]] == ["kept"]


def test_an_edited_journal_line_or_header_breaks_the_chain(record: RunRecord):
    for name in ("a", "b", "c"):
        record.add_test({"test_id": name, "outcome": "failed"})
    journal = record.path / JOURNAL_FILE
    assert "journal_problems" not in load_record(record.path)
    assert verify_record(record.path) == []
    lines = journal.read_text().splitlines(keepends=True)
    edited = lines[1].replace('"failed"', '"passed"')
    journal.write_text(lines[0] + edited + lines[2])
    data = load_record(record.path)
    assert [t["outcome"] for t in data["tests"]] == ["failed", "passed", "failed"]
    assert len(data["journal_problems"]) == 1 and "line 2" in data["journal_problems"][0]
    assert any("line 2 does not match its hash chain" in p for p in verify_record(record.path))
    journal.write_text("".join(lines))
    header = record.path / "record.json"
    header.write_text(header.read_text().replace('"running"', '"running" '))
    assert "line 1" in load_record(record.path)["journal_problems"][0]


def test_a_reopened_record_continues_the_chain(record: RunRecord):
    record.add_test({"test_id": "a", "outcome": "passed"})
    reopened = RunRecord.open(record.path)
    reopened.add_test({"test_id": "b", "outcome": "passed"})
    assert "journal_problems" not in load_record(record.path)
