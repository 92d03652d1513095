"""Follow one run record folder while its run goes on (design.md §10: the station is a sink).

A running record is its header ``record.json`` plus one line per event appended to
``journal.jsonl``; :class:`RecordFollower` reads only the bytes added since its last poll and
applies each complete line with :func:`hil.record.apply_event` (the same fold
:func:`hil.record.load_record` replays), so a poll costs O(new events). When the run finishes,
``record.json`` is rewritten whole and sealed and the journal removed: the follower then takes
the sealed ``record.json`` as the truth. It never writes and never locks anything, so it cannot
make the run fail or wait.
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

from hil.errors import InputError
from hil.record import JOURNAL_FILE, RECORD_FILE, apply_event, load_record


class RecordFollower:
    """The current state of one record folder, brought up to date by :meth:`poll`."""

    def __init__(self, folder: str | Path) -> None:
        self.folder = Path(folder)
        self.data: dict | None = None
        #: Every journal event applied, in order, each with ``seen_s`` (time.time() when read).
        self.events: list[dict] = []
        self._offset = 0
        self._header_stamp: tuple[int, int] | None = None

    @property
    def finished(self) -> bool:
        return self.data is not None and self.data.get("status") != "running"

    def poll(self) -> bool:
        """Read what was added since the last poll; True when anything changed."""
        if self.finished:
            return False
        changed = self._read_header()
        if self.data is None or self.finished:
            return changed
        try:
            with open(self.folder / JOURNAL_FILE, "rb") as handle:
                handle.seek(self._offset)
                chunk = handle.read()
        except FileNotFoundError:           # not yet written, or removed by RunRecord.finish
            return self._read_header() or changed
        complete = chunk[:chunk.rfind(b"\n") + 1]   # a torn last line waits for its newline
        if not complete:
            return changed
        now = time.time()
        for line in complete.decode("utf-8").splitlines():
            event = json.loads(line)
            apply_event(self.data, event)
            self.events.append(event | {"seen_s": now})
        self._offset += len(complete)
        return True

    def _read_header(self) -> bool:
        """(Re)read ``record.json`` when it changed: created, or rewritten sealed at the end."""
        path = self.folder / RECORD_FILE
        try:
            stat = path.stat()
        except FileNotFoundError:
            return False
        stamp = (stat.st_mtime_ns, stat.st_size)
        if stamp == self._header_stamp:
            return False
        try:
            header = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, json.JSONDecodeError):
            return False
        self._header_stamp = stamp
        if header.get("status") != "running":
            self.data = load_record(self.folder)      # the sealed record is the truth
            return True
        if self.data is None:
            for key, default in (("pending_captures", []), ("calibration_overrides", []),
                                 ("decision_rule", {})):
                header.setdefault(key, default)
            self.data = header
            self._offset = 0
            return True
        return False


def find_record(root: str | Path, token: str, not_before_s: float) -> Path | None:
    """The record folder under ``root`` whose run's command line carries ``token`` (the
    station's mark on the child run it started), created at or after ``not_before_s``."""
    root = Path(root)
    try:
        entries = list(os.scandir(root))
    except FileNotFoundError:
        return None
    for entry in entries:
        header = Path(entry.path) / RECORD_FILE
        try:
            if not entry.is_dir() or header.stat().st_mtime < not_before_s - 1:
                continue
            data = json.loads(header.read_text(encoding="utf-8"))
        except (OSError, json.JSONDecodeError):
            continue
        if token in str((data.get("run") or {}).get("command_line", "")):
            return Path(entry.path)
    return None


def read_record(folder: str | Path) -> dict | None:
    """A record as :func:`hil.record.load_record` reads it, or None when it is not readable."""
    try:
        return load_record(folder)
    except InputError:
        return None
