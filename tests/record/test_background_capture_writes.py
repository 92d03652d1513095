"""Captures written in the record's writer thread (issue 33) keep the record's promises: a
storage fault of the raw data stops the run even when the point fails for another reason too,
no later point is driven, the record closes while writes are queued, nothing hangs (review h-27)."""

from __future__ import annotations

import errno
import os
import threading

import pytest

import hil.capture
from hil.errors import HilError
from hil.measurement import PointPlan, measure_point
from hil.record import RecordWriteError, load_record, storage_error_of
from hil.sim.defects import DriveDefects

from test_record import small_capture

pytestmark = [pytest.mark.timeout(120)]


class FullDiskOs:
    """``os`` with every fsync failing ENOSPC (the capture's atomic write fsyncs its file)."""

    def __getattr__(self, name):
        return getattr(os, name)

    def fsync(self, fd):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


BASELINE = PointPlan(source="baseline", injection={}, speed_rpm=500.0, current_a=20.0,
                     revolutions=2)


def test_a_storage_fault_outranks_the_points_other_failure(sim_bench, run_record, monkeypatch):
    sim_bench.simulated.twin.defects = DriveDefects(daq_drop_every_nth=10)   # integrity fails
    monkeypatch.setattr(hil.capture, "os", FullDiskOs())
    with pytest.raises(RecordWriteError) as info:
        measure_point(sim_bench, run_record, "dropping-daq", BASELINE)
    monkeypatch.undo()
    assert storage_error_of(info.value) is not None            # what stops the run
    assert "CaptureIntegrityError" in repr(info.value.__cause__)   # the other failure chained
    entry = run_record.tests[-1]
    assert entry["outcome"] == "error" and "RecordWriteError" in entry["error"]
    sim_bench.simulated.twin.defects = DriveDefects()
    with pytest.raises(RecordWriteError):                      # no later point is driven
        measure_point(sim_bench, run_record, "after-the-fault", BASELINE)
    assert run_record.test("after-the-fault")["outcome"] == "error"
    assert not (run_record.path / "captures" / "after-the-fault.npz").exists()


def test_finish_while_a_write_is_queued_neither_hangs_nor_loses_it(run_record, monkeypatch):
    started, release = threading.Event(), threading.Event()
    save = hil.capture.Capture.save

    def slow_save(self, path):
        started.set()
        release.wait(10)
        return save(self, path)

    monkeypatch.setattr(hil.capture.Capture, "save", slow_save)
    run_record.save_capture_later("first", small_capture())
    started.wait(10)
    run_record.save_capture_later("queued", small_capture())    # behind the first
    finisher = threading.Thread(target=run_record.finish, args=("interrupted",))
    finisher.start()
    with pytest.raises(HilError, match="being closed|already finished"):
        run_record.save_capture_later("too late", small_capture())
    release.set()
    finisher.join(20)
    assert not finisher.is_alive()
    data = load_record(run_record.path)
    assert data["status"] == "interrupted"
    assert sorted(p["test_id"] for p in data["pending_captures"]) == ["first", "queued"]
