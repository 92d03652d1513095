"""The station's journal follower reads a run record while it is written, as load_record would."""

from __future__ import annotations

import numpy as np

from hil.capture import Capture
from hil.config import default_sim_bench
from hil.record import JOURNAL_FILE, RunRecord, load_record
from hil.station.journal import RecordFollower, find_record


def _capture() -> Capture:
    t = np.arange(100) / 1000.0
    return Capture(channels={"time_s": t, "torque_nm": np.ones_like(t)},
                   meta={"sample_rate_hz": 1000.0})


def _comparable(data: dict) -> dict:
    return {k: v for k, v in data.items() if k != "journal_problems"}


def test_follows_events_as_written_then_takes_the_sealed_record(tmp_path):
    record = RunRecord.create(tmp_path, default_sim_bench(), [],
                              sections={"run": {"command_line": "hil run -- --hil-station-run "
                                                                "tok123"}})
    follower = RecordFollower(record.path)
    assert follower.poll() and follower.data["status"] == "running"
    assert not follower.poll()                        # nothing new: no change
    record.save_capture("t1", _capture())
    record.add_test({"test_id": "t1", "outcome": "passed", "source": "baseline"})
    record.set_section("unit", {"serial_number": "SN-1"})
    assert follower.poll()
    assert [e["event"] for e in follower.events] == ["capture", "test", "section"]
    assert _comparable(follower.data) == _comparable(load_record(record.path))
    assert follower.data["tests"][0]["capture"]["file"].startswith("captures/")
    record.add_test({"test_id": "t2", "outcome": "failed", "source": "baseline"})
    record.finish("interrupted")
    assert follower.poll() and follower.finished
    assert follower.data == load_record(record.path)
    assert [t["outcome"] for t in follower.data["tests"]] == ["passed", "failed"]
    assert find_record(tmp_path, "tok123", 0) == record.path
    assert find_record(tmp_path, "other-token", 0) is None


def test_a_torn_last_line_waits_for_its_end(tmp_path):
    record = RunRecord.create(tmp_path, default_sim_bench(), [])
    follower = RecordFollower(record.path)
    follower.poll()
    journal = record.path / JOURNAL_FILE
    line = '{"event":"section","name":"note","data":{"text":"half"}}\n'
    with open(journal, "a", encoding="utf-8") as handle:
        handle.write(line[:20])
    assert not follower.poll() and "note" not in follower.data
    with open(journal, "a", encoding="utf-8") as handle:
        handle.write(line[20:])
    assert follower.poll() and follower.data["note"] == {"text": "half"}
