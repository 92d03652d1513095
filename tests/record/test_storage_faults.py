"""Storage faults stop the run safely (issue 22 item 6, item 8's read-only record folder).

A full disk (ENOSPC) while the run writes its journal or a capture stops the run at once, like a
lost bench: the drive is made safe, one line on stderr names the file and the errno, exit code 8
(``hil.record.EXIT_STORAGE``), no later test is driven (no capture, "not run"), and the record
keeps what was written, closed as ``storage-error`` when it still can be, or says it could not.
An unwritable record root or report path is refused before the bench is touched (exit 2, one
line), never "bench not opened" (exit 6).

The full disk is simulated in the pytest process by a ``conftest.py`` that makes ``os.fsync``
of the record's journal fail with ENOSPC after N lines (and, with ``FULL_DISK_EVERYTHING``, every
later write of the record and its captures too); the bench is the in-process simulated one.
"""

from __future__ import annotations

import errno
import os
import subprocess
import sys
from pathlib import Path

import pytest

from hil.outcome_kinds import MEASURED
from hil.errors import InputError
from hil.record import EXIT_STORAGE, load_record
from hil.seal import KEY_DIR_ENV

pytestmark = pytest.mark.timeout(300)

PLAN = '''
from hil.measurement import PointPlan


def point(measure):
    measure(PointPlan(source="baseline", injection={}, speed_rpm=500.0, current_a=20.0,
                      revolutions=2, rule=None))


def test_first(measure):
    point(measure)


def test_second(measure):
    point(measure)


def test_third(measure):
    point(measure)


def test_fourth(measure):
    point(measure)
'''

FULL_DISK = '''
import errno
import os

import hil.capture
import hil.record

FAIL_AFTER = int(os.environ["FULL_DISK_AFTER_JOURNAL_LINES"])
EVERYTHING = bool(os.environ.get("FULL_DISK_EVERYTHING"))
state = {"lines": 0, "full": bool(os.environ.get("FULL_DISK_AT_START"))}


def enospc():
    return OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


class JournalOs:
    """``os`` for hil.record: fsync of the journal fails once FAIL_AFTER lines are written."""

    def __getattr__(self, name):
        return getattr(os, name)

    def fsync(self, fd):
        state["lines"] += 1
        if state["lines"] > FAIL_AFTER:
            state["full"] = True
            raise enospc()
        return os.fsync(fd)


class FilesOs:
    """``os`` for hil.capture (captures, record.json, seal): fails once the disk is full."""

    def __getattr__(self, name):
        return getattr(os, name)

    def fsync(self, fd):
        if EVERYTHING and state["full"]:
            raise enospc()
        return os.fsync(fd)


hil.record.os = JournalOs()
hil.capture.os = FilesOs()
'''


def run_plan(tmp_path: Path, fail_after: int, everything: bool = False, *extra: str):
    (tmp_path / "test_points.py").write_text(PLAN)
    (tmp_path / "conftest.py").write_text(FULL_DISK)
    env = dict(os.environ, FULL_DISK_AFTER_JOURNAL_LINES=str(fail_after),
               **{KEY_DIR_ENV: str(tmp_path / "keys")})
    env.pop("FULL_DISK_EVERYTHING", None)
    if everything:
        env["FULL_DISK_EVERYTHING"] = "1"
    done = subprocess.run([sys.executable, "-m", "pytest", "test_points.py", "-q",
                           "-p", "no:cacheprovider", "--hil-record", str(tmp_path / "records"),
                           *extra],
                          capture_output=True, text=True, timeout=280, cwd=tmp_path, env=env)
    header = next((tmp_path / "records").glob("*/record.json"), None)
    return done, header.parent if header is not None else None


@pytest.mark.parametrize("everything", [False, True], ids=["journal-only", "whole-disk"])
def test_a_full_disk_mid_run_stops_at_once_with_the_drive_safe(tmp_path, everything):
    # journal lines of a run: sections and requirements at the start, the characterisation
    # stage's captures and section, then per point a capture and its test entry; 10 lets the
    # first point finish and fills the disk inside a later one
    done, folder = run_plan(tmp_path, 10, everything)
    output = done.stdout + done.stderr
    assert done.returncode == EXIT_STORAGE, output[-4000:]
    # each place that names the fault once (no 171 lines of tracebacks): the failed test's
    # report, pytest's short summary and its "Interrupted" line, the summary's RECORD STORAGE
    # FAILED line and the one stderr line; pytest's -ra adds a line in some environments
    assert "Traceback" not in output and output.count("ENOSPC") <= 6, output[-4000:]
    assert output.count("ripple-hil: run stopped, the record cannot be written") == 1
    stderr_lines = [line for line in done.stderr.splitlines() if line.strip()]
    assert len(stderr_lines) == 1, done.stderr
    line = stderr_lines[0]
    assert line.startswith("ripple-hil: run stopped, the record cannot be written: ")
    assert "journal.jsonl" in line and "No space left on device (ENOSPC)" in line
    assert "drive made safe" in line
    record = load_record(folder)
    names = [t["test_id"].rsplit("::", 1)[-1] for t in record["tests"]]
    captured = [p.name for p in (folder / "captures").glob("*.npz")]
    assert any("test_first" in name for name in captured), captured
    assert not [n for n in captured if "test_third" in n or "test_fourth" in n], captured
    assert record["tests"][0]["outcome"] == MEASURED          # rule None: nothing judged
    if everything:
        # nothing more could be written: the folder keeps the header and the journal lines
        # written before the fault (status running), and the line says it was not closed
        assert record["status"] == "running" and names[0] == "test_first"
        assert "could NOT be closed" in line and "status running" in line
        return
    # the journal failed, the final record.json could still be written: every test is in it
    assert record["status"] == "storage-error", record["status"]
    assert names == ["test_first", "test_second", "test_third", "test_fourth"]
    assert record["run"]["storage_error"]["errno_name"] == "ENOSPC"
    assert record["run"]["final_safe_state"] is not None
    assert "closed as storage-error" in line
    hit = [i for i, t in enumerate(record["tests"]) if "ENOSPC" in (t.get("message") or "")
           and t["outcome"] != "not run"]
    assert len(hit) == 1, record["tests"]          # the one test during which the disk filled
    stopped = hit[0]
    assert 0 < stopped < 3, record["tests"]
    assert all(t["outcome"] == MEASURED for t in record["tests"][:stopped])
    assert record["tests"][stopped]["outcome"] in ("failed", "error")
    assert all(t["outcome"] == "not run" for t in record["tests"][stopped + 1:])


def test_a_full_disk_before_the_start_is_bad_input_on_stderr(tmp_path, monkeypatch):
    """The header of the record cannot be written (a full disk, the folder itself creatable):
    exit 2 with one line on stderr, as the README says, not exit 8 on stdout; no test runs."""
    monkeypatch.setenv("FULL_DISK_AT_START", "1")
    done, folder = run_plan(tmp_path, 0, True)
    assert done.returncode == 2, done.stdout[-3000:] + done.stderr[-3000:]
    lines = [line for line in done.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("ripple-hil: the record cannot be written, "
                                                   "no test run"), done.stderr
    assert "No space left on device" in lines[0]
    assert "the record cannot be written" not in done.stdout
    assert folder is None or not list(folder.glob("captures/*.npz"))


def test_an_unwritable_record_root_is_refused_before_the_bench(tmp_path):
    """Item 8: not exit 6 "bench not opened" but a storage error, before any bench command."""
    (tmp_path / "test_points.py").write_text(PLAN)
    blocker = tmp_path / "not-a-folder"
    blocker.write_text("a file where the record root should be")
    env = dict(os.environ, **{KEY_DIR_ENV: str(tmp_path / "keys")})
    done = subprocess.run([sys.executable, "-m", "pytest", "test_points.py", "-q",
                           "-p", "no:cacheprovider", "--hil-record", str(blocker / "records")],
                          capture_output=True, text=True, timeout=120, cwd=tmp_path, env=env)
    output = done.stdout + done.stderr
    assert done.returncode == 2, output[-3000:]
    assert "bench not opened" not in output and "Traceback" not in output
    assert "the record cannot be stored, no test run (nothing sent to the bench)" in output
    assert "Not a directory (ENOTDIR)" in output


def test_hil_run_refuses_unwritable_record_dir_and_report_path(tmp_path, monkeypatch):
    """``hil run`` checks both before pytest starts: exit 2 with one line, no bench."""
    from hil.cli import main
    import hil.record

    monkeypatch.setenv(KEY_DIR_ENV, str(tmp_path / "keys"))
    blocker = tmp_path / "file"
    blocker.write_text("")
    assert main(["run", "--source", "baseline", "--record-dir", str(blocker / "r")]) == 2

    def read_only(folder):
        raise hil.record.RecordWriteError(folder, OSError(errno.EROFS, os.strerror(errno.EROFS)),
                                          "write in")

    monkeypatch.setattr(hil.record, "check_writable_folder", read_only)
    with pytest.raises(InputError, match=r"-o .*report.pdf: cannot write in .*Read-only file "
                                         r"system \(EROFS\)"):
        from hil.commands import run as run_command
        import argparse

        parser = argparse.ArgumentParser()
        run_command.register(parser.add_subparsers())
        run_command.build_pytest_args(parser.parse_args(
            ["run", "--source", "baseline", "-o", str(tmp_path / "report.pdf")]))
    assert not (tmp_path / "r").exists()


def test_check_writable_folder_probes_without_leaving_anything(tmp_path):
    from hil.record import RecordWriteError, check_writable_folder

    check_writable_folder(tmp_path / "not" / "yet")
    assert list(tmp_path.iterdir()) == []
    (tmp_path / "f").write_text("")
    with pytest.raises(RecordWriteError, match="ENOTDIR"):
        check_writable_folder(tmp_path / "f" / "records")


def test_the_session_refuses_unstorable_paths_before_the_bench(tmp_path, monkeypatch):
    """``HilSession.storage_problem`` (the plugin asks before opening the bench): one line
    naming the option as the user typed it; None when everything can be written."""
    from ripple_hil_fixtures.session import HilSession, SessionOptions

    monkeypatch.setenv(KEY_DIR_ENV, str(tmp_path / "keys"))
    blocker = tmp_path / "file"
    blocker.write_text("")
    flags = {"--hil-record": "--record-dir", "--hil-report": "-o"}

    def problem(**options):
        return HilSession(SessionOptions(flags=flags, **options)).storage_problem()

    assert problem(record_root=tmp_path / "records", report_path="auto") is None
    assert problem(record_root=blocker / "records").startswith(
        f"--record-dir {blocker / 'records'}: cannot create a folder in {blocker}")
    assert "the file exists and a report is never overwritten" in problem(
        record_root=tmp_path / "records", report_path=str(blocker))
    (tmp_path / "keys" / "station_ed25519").write_text("not a key")     # made by the 1st call
    (tmp_path / "keys" / "station_ed25519").chmod(0o600)
    assert "is not a PEM private key" in problem(record_root=tmp_path / "records")
    assert not (tmp_path / "records").exists()
