"""Run records: one folder per run, ``record.json`` plus ``captures/<test-id>.npz``.

Writing costs O(new data) and survives a crash (issue 17 item 3): :meth:`RunRecord.create` writes
``record.json`` once with the run's header (status ``running``, no tests); every later change —
a capture saved, a test entry, an outcome, a section — is one line appended (and fsynced) to
``journal.jsonl``; :meth:`RunRecord.finish` writes the whole ``record.json`` once, seals it with
``record.sha256`` and removes the journal. :func:`load_record` replays a journal it finds, so a
run killed mid-way reads back with every event it had written and status ``running``.

The journal is hash-chained: each line carries ``chain`` = SHA-256 of the previous line's
``chain`` (for line 1, of the header ``record.json`` as created) and of the line's own event, so
an edited line — or an edited header — is found by :func:`load_record` (``journal_problems``) and
:func:`verify_record`. Without a secret key this is evidence of careless or partial edits, not a
signature: whoever rewrites every later line can forge the chain, and lines cut from the end
leave no trace. An unsealed record (a run killed before :meth:`RunRecord.finish`) is never
"intact": ``hil verify`` says it is not sealed. The seal is signed with the station's Ed25519 key
(``record.sig``, :mod:`hil.seal`), which a user who re-hashes an edited record cannot redo.

Storage faults (issue 22 item 6): any ``OSError`` writing the record (a full disk, a read-only
or forbidden folder) raises :class:`RecordWriteError`, one line naming the file and the errno.
The journal is then abandoned (a torn line may end it: :func:`load_record` drops it), later
events are kept in memory only, and :meth:`RunRecord.finish` tries once to write the whole
record and its seal; if that fails too, the folder keeps what was written (header and journal,
status ``running``) and the error says so. A run stopped by a storage fault ends with status
``storage-error`` and exit code :data:`EXIT_STORAGE`.

A test's raw capture is saved *before* it is analysed (:meth:`RunRecord.save_capture`); until its
test entry is added, the capture is listed under ``pending_captures`` so its SHA-256 is never lost.
Every pytest outcome has an entry (``passed``, ``failed``, ``error``, ``skipped``, ``xfailed``,
``xpassed``, ``not run``), whether or not the test measured. ``status`` is ``running`` until
:meth:`RunRecord.finish` sets one of :data:`FINAL_STATUSES`: ``complete`` only when every
selected test ran to its end on a live bench. Schema: ``"format": "ripple-hil-record/2"``.
"""

from __future__ import annotations

import copy
import hashlib
import importlib.metadata
import json
import math
import os
import platform
import re
import secrets
import subprocess
import threading
from concurrent.futures import Future, ThreadPoolExecutor
from datetime import date, datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np

import hil
from hil.capture import Capture, atomic_write_bytes
from hil.config import BenchConfig
from hil.errors import HilError, InputError
from hil.outcome_kinds import MEASURED, NOT_DETERMINABLE

#: ``hil run`` / pytest exit code of a run stopped because its record could not be written.
EXIT_STORAGE = 8
#: ``hil run`` / pytest exit code of a run that finished yet judged nothing: no model verdict,
#: no requirement verdict (only points measured with no verdict, not determinable here, or the
#: bench self-check): not a pass (``reports.statement.judged_tests``).
EXIT_NOTHING_JUDGED = 9

FORMAT = "ripple-hil-record/2"
#: Formats :func:`load_record` reads (version 1: record.json rewritten per test, no seal).
READABLE_FORMATS = (FORMAT, "ripple-hil-record/1")
RECORD_FILE = "record.json"
JOURNAL_FILE = "journal.jsonl"
SEAL_FILE = "record.sha256"
CAPTURE_DIR = "captures"
#: ``complete``: every selected test ran to its end on a live bench; ``interrupted``: Ctrl-C;
#: ``aborted``: the bench was lost (``run.abort`` says which instrument and when); ``stopped``:
#: pytest stopped early (-x / --maxfail); ``partial-selection``: some collected points were
#: deselected (-k, -m, --deselect); ``failed``: the session itself failed (internal error);
#: ``storage-error``: the record could not be written (``run.storage_error`` says which file
#: and errno) and the run was stopped there.
STATUSES = ("running", "complete", "interrupted", "aborted", "stopped", "partial-selection",
            "failed", "storage-error")
FINAL_STATUSES = STATUSES[1:]
OUTCOMES = ("passed", "failed", "error", "skipped", "xfailed", "xpassed", "not run",
            NOT_DETERMINABLE, MEASURED)
#: Outcomes that make a statement of conformity impossible to give as PASS.
BAD_OUTCOMES = ("failed", "error")
KINDS = ("measurement", "self_check", "ripple_map", "diagnosis", "other")
PHASES = ("setup", "call", "teardown")
#: Distributions whose versions every record lists.
PACKAGES = ("numpy", "scipy", "numba", "python-can", "canopen", "pymodbus", "pyserial",
            "matplotlib", "fpdf2", "pytest")
_TEST_KEYS = ("test_id", "nodeid", "source", "kind", "started_utc", "finished_utc", "outcome",
              "phase", "message", "injection", "operating_point", "capture", "measured",
              "prediction", "uncertainty", "verdict", "requirements", "checks", "notes", "error")
#: Test-entry fields that :meth:`RunRecord.update_test` may change after the entry is added.
_UPDATABLE_KEYS = ("outcome", "phase", "message", "kind", "requirements", "checks", "notes",
                   "finished_utc", "error")
#: Top-level keys that :meth:`RunRecord.set_section` must not replace.
_RESERVED = ("format", "record_id", "created_utc", "finished_utc", "status", "software", "bench",
             "instruments", "tests", "pending_captures", "calibration_overrides",
             "decision_rule", "seal")
_INSTRUMENT_KEYS = ("role", "model", "serial_number", "range", "accuracy_class", "resolution",
                    "calibration_date", "calibration_due")


class RecordWriteError(HilError):
    """The run record could not be written: ``path`` (the file), ``errno`` and ``strerror`` of
    the operating system's error (ENOSPC, EROFS, EACCES, ...)."""

    def __init__(self, path: str | Path, error: OSError, what: str = "write") -> None:
        import errno as _errno

        self.path = str(path)
        self.errno = error.errno
        self.errno_name = _errno.errorcode.get(error.errno or 0, "no errno")
        self.strerror = error.strerror or str(error)
        super().__init__(f"cannot {what} {self.path}: {self.strerror} ({self.errno_name})")

    def to_dict(self) -> dict:
        return {"path": self.path, "errno": self.errno, "errno_name": self.errno_name,
                "strerror": self.strerror}


def storage_error_of(error: BaseException | None) -> "RecordWriteError | None":
    """The :class:`RecordWriteError` behind ``error`` (itself, its cause or context), if any."""
    seen = set()
    while error is not None and id(error) not in seen:
        if isinstance(error, RecordWriteError):
            return error
        seen.add(id(error))
        error = error.__cause__ or error.__context__
    return None


def check_writable_folder(folder: str | Path) -> None:
    """RecordWriteError unless files can be created in ``folder`` (or, if it does not exist
    yet, in its nearest existing parent): probed by creating and removing an empty file, which
    also catches a read-only mount or a root that ignores permission bits. Leaves nothing."""
    import errno as _errno
    import tempfile

    folder = Path(folder).absolute()
    existing = next((p for p in (folder, *folder.parents) if p.exists()), Path("/"))
    if not existing.is_dir():
        raise RecordWriteError(existing, NotADirectoryError(
            _errno.ENOTDIR, os.strerror(_errno.ENOTDIR)), "create a folder in")
    try:
        handle, probe = tempfile.mkstemp(dir=existing, prefix=".ripple-hil-probe-")
        os.close(handle)
        os.unlink(probe)
    except OSError as exc:
        raise RecordWriteError(existing, exc, "write in") from None


def utc_now() -> str:
    """The current UTC time as ISO 8601 with a ``Z`` suffix, to the second."""
    return datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")


def new_record_id(now: datetime | None = None) -> str:
    """A unique record id: UTC timestamp and six random hex digits (``20261121T053000Z-3fa2c1``)."""
    now = now or datetime.now(timezone.utc)
    return f"{now.strftime('%Y%m%dT%H%M%SZ')}-{secrets.token_hex(3)}"


def safe_test_name(test_id: str) -> str:
    """A file-name stem for a test id that cannot leave the captures folder.

    Characters other than letters, digits, ``.``, ``_``, ``-`` become ``_``; leading dots are
    dropped (no ``..``, no hidden files). When the id had to change, a short hash of the original
    keeps two different ids from mapping to the same file.
    """
    if not isinstance(test_id, str) or not test_id.strip():
        raise InputError(f"test_id must be a non-empty string, got {test_id!r}")
    cleaned = re.sub(r"[^A-Za-z0-9._-]+", "_", test_id).lstrip("._-")[:120] or "test"
    if cleaned != test_id:
        cleaned = f"{cleaned}-{hashlib.sha256(test_id.encode()).hexdigest()[:8]}"
    return cleaned


def to_jsonable(value: Any) -> Any:
    """Opaque result dicts (``to_dict()`` output) as strict JSON: numpy scalars and arrays become
    numbers and lists, paths and dates strings, non-finite floats ``null``."""
    if isinstance(value, dict):
        return {str(key): to_jsonable(item) for key, item in value.items()}
    if isinstance(value, (list, tuple, set, frozenset)):
        return [to_jsonable(item) for item in value]
    if isinstance(value, np.ndarray):
        return to_jsonable(value.tolist())
    if isinstance(value, np.generic):
        return to_jsonable(value.item())
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, complex):
        return {"re": to_jsonable(value.real), "im": to_jsonable(value.imag)}
    if isinstance(value, (datetime, date)):
        return value.isoformat()
    if isinstance(value, Path):
        return str(value)
    if hasattr(value, "to_dict"):
        return to_jsonable(value.to_dict())
    if value is None or isinstance(value, (bool, int, str)):
        return value
    raise InputError(f"record: cannot store a {type(value).__name__} ({value!r}) as JSON")


def software_info() -> dict:
    """Version, git commit and dirty flag of this checkout, Python and package versions."""
    repo = Path(hil.__file__).resolve().parent.parent
    git_sha = _git(repo, "rev-parse", "HEAD")
    dirty = _git(repo, "status", "--porcelain", "--untracked-files=no")
    packages = {}
    for name in PACKAGES:
        try:
            packages[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            packages[name] = None
    return {"version": hil.__version__, "git_sha": git_sha,
            "git_dirty": None if git_sha is None or dirty is None else bool(dirty),
            "python": platform.python_version(), "platform": platform.platform(),
            "packages": packages}


def _git(repo: Path, *args: str) -> str | None:
    try:
        done = subprocess.run(["git", "-C", str(repo), *args], capture_output=True, text=True,
                              timeout=10, check=False)
    except (OSError, subprocess.TimeoutExpired):
        return None
    return done.stdout.strip() if done.returncode == 0 else None


def instrument_table(bench: BenchConfig, identities: list[dict]) -> list[dict]:
    """The bench file's ``[[instrument]]`` entries, each with the identity queried from it.

    An identity dict carries ``role`` and either an ``identity`` sub-dict or its fields flat.
    A queried ``serial_number`` that differs from the bench file's is listed in ``problems``.
    """
    queried: dict[str, dict] = {}
    for item in identities:
        if not isinstance(item, dict) or "role" not in item:
            raise InputError(f"record: an instrument identity must be a dict with a 'role', "
                             f"got {item!r}")
        body = item.get("identity", {k: v for k, v in item.items() if k != "role"})
        queried[item["role"]] = to_jsonable(body)
    table = []
    for entry in bench.instruments:
        row = {key: to_jsonable(getattr(entry, key)) for key in _INSTRUMENT_KEYS}
        row["identity"] = queried.pop(entry.role, {})
        row["problems"] = []
        serial = row["identity"].get("serial_number")
        if serial is not None and str(serial) != entry.serial_number:
            row["problems"].append(f"queried serial number {serial!r} differs from the bench "
                                   f"file's {entry.serial_number!r}")
        table.append(row)
    for role, identity in queried.items():  # instruments the bench file does not describe
        row = {key: None for key in _INSTRUMENT_KEYS} | {"role": role, "identity": identity}
        row["model"] = identity.get("model")
        row["serial_number"] = identity.get("serial_number")
        row["problems"] = ["not described in the bench file (no calibration data)"]
        table.append(row)
    return table


class RunRecord:
    """A run record folder being written (or reopened). Every public method is thread-safe."""

    def __init__(self, path: Path, data: dict) -> None:
        self.path = Path(path)
        self.data = data
        self._lock = threading.RLock()
        self._journal = None
        self._chain: str | None = None
        #: the first storage fault (journal abandoned: later events kept in memory only)
        self.write_error: RecordWriteError | None = None
        #: captures being written by the writer thread, by test id (:meth:`save_capture_later`)
        self._writing: dict[str, Future] = {}
        self._writer: ThreadPoolExecutor | None = None
        self._closing = False

    # ------------------------------------------------------------------ create / open
    @classmethod
    def create(cls, root: str | Path, bench: BenchConfig, instruments: list[dict], *,
               decision_rule: dict | None = None, name: str | None = None,
               sections: dict | None = None) -> "RunRecord":
        """Start a record in ``root/<name or record_id>`` and write its header ``record.json``.

        ``instruments``: identities as queried from the instruments (see
        :func:`instrument_table`). ``decision_rule`` may also be set later, before the first test;
        ``sections``: top-level sections known at the start (``run``, ``lab``, ``sim_defects``).
        """
        record_id = new_record_id()
        folder = Path(root) / (safe_test_name(name) if name else record_id)
        if (folder / RECORD_FILE).exists():
            raise InputError(f"record folder {str(folder)!r} already holds a {RECORD_FILE}")
        try:
            (folder / CAPTURE_DIR).mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise RecordWriteError(exc.filename or folder / CAPTURE_DIR, exc, "create") from exc
        data = {
            "format": FORMAT,
            "record_id": record_id,
            "created_utc": utc_now(),
            "finished_utc": None,
            "status": "running",
            "software": software_info(),
            "bench": {"path": bench.source, "sha256": bench.sha256, "simulated": bench.simulated,
                      "loaded": bench.to_dict()},
            "instruments": instrument_table(bench, instruments),
            "calibration_overrides": [],
            "decision_rule": to_jsonable(decision_rule or {}),
            "requirements_source": None,
            "sim_defects": {},
            "tests": [],
            "pending_captures": [],
        }
        for key, value in (sections or {}).items():
            _check_section_name(key)
            data[key] = to_jsonable(value)
        record = cls(folder, data)
        try:
            _write_json(folder / RECORD_FILE, data)
        except OSError as exc:
            raise RecordWriteError(folder / RECORD_FILE, exc) from exc
        return record

    @classmethod
    def open(cls, path: str | Path) -> "RunRecord":
        """Reopen a record folder (or its ``record.json``), validating its format."""
        folder = _record_folder(path)
        return cls(folder, load_record(folder))

    def __enter__(self) -> "RunRecord":
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        """Finish as ``interrupted`` on Ctrl-C, ``failed`` on an exception, else ``complete``."""
        if self.data["status"] != "running":
            return
        if exc_type is not None and issubclass(exc_type, KeyboardInterrupt):
            self.finish("interrupted")
        elif exc_type is not None:
            self.finish("failed")
        else:
            self.finish("complete")

    # ------------------------------------------------------------------ properties
    @property
    def record_id(self) -> str:
        return self.data["record_id"]

    @property
    def status(self) -> str:
        return self.data["status"]

    @property
    def tests(self) -> list[dict]:
        return self.data["tests"]

    def test(self, test_id: str) -> dict | None:
        """The entry of ``test_id``, or None if it has none yet."""
        with self._lock:
            return next((t for t in self.data["tests"] if t["test_id"] == test_id), None)

    # ------------------------------------------------------------------ writing
    def set_decision_rule(self, rule: dict) -> None:
        """Store the decision rule; refused once a test is recorded (agreed before measuring)."""
        with self._lock:
            self._require_running()
            if self.data["tests"]:
                raise HilError("record: the decision rule must be agreed before the first test "
                               f"is recorded; {len(self.data['tests'])} test(s) already are")
            self._apply({"event": "decision_rule", "rule": to_jsonable(rule)})

    def set_section(self, name: str, data: dict) -> None:
        """Store a top-level section (``diagnosis``, ``run``, ``requirements_source``, …);
        a later call for the same name replaces it."""
        _check_section_name(name)
        with self._lock:
            self._require_running()
            self._apply({"event": "section", "name": name, "data": to_jsonable(data)})

    def add_calibration_override(self, role: str, serial_number: str, due: str | date,
                                 reason: str, by: str) -> None:
        """Record that an instrument past its calibration due date was used, why and by whom."""
        if not reason or not by:
            raise InputError("record: a calibration override needs a reason and a name (by)")
        with self._lock:
            self._require_running()
            self._apply({"event": "override", "override": to_jsonable(
                {"role": role, "serial_number": serial_number, "due": due, "reason": reason,
                 "by": by})})

    def save_capture(self, test_id: str, capture: Capture) -> dict:
        """Write the raw capture of ``test_id`` to ``captures/`` now, before any analysis.

        Returns ``{file, sha256, n_samples, sample_rate_hz}`` (``file`` relative to the record
        folder) and lists it under ``pending_captures`` until the test entry is added.
        """
        return self.save_capture_later(test_id, capture).result()

    def save_capture_later(self, test_id: str, capture: Capture) -> Future:
        """Start writing the raw capture of ``test_id`` (as :meth:`save_capture`) in the record's
        one writer thread and return at once; the Future gives :meth:`save_capture`'s dict or
        raises its :class:`RecordWriteError`. The capture is encoded from a copy taken now
        (channels and meta; a memory copy costs ~1 % of the deflate), so what the point does to
        it afterwards never reaches the file.

        The point analyses while its raw data is deflated and written (zlib, hashing and the
        file writes release the GIL): issue 33 measured 1.6 s of the default run's 20 s in this
        write. Ordering is kept: the capture's journal event is written before its test entry
        (:meth:`add_test` waits for it) and :meth:`finish` waits for every capture, so a sealed
        record never names a capture that is not on disk.
        """
        name = safe_test_name(test_id)
        relative = f"{CAPTURE_DIR}/{name}.npz"
        target = self.path / relative
        snapshot = Capture(channels={name: np.array(values, copy=True)
                                     for name, values in capture.channels.items()},
                           units=dict(capture.units), meta=copy.deepcopy(capture.meta))
        with self._lock:
            self._require_running()
            if self._closing:
                raise HilError(f"record {self.record_id}: being closed; the capture of test "
                               f"{test_id!r} cannot be added")
            if test_id in self._writing or target.exists():
                raise HilError(f"record: a capture for test {test_id!r} already exists "
                               f"({relative}); test ids must be unique within a run")
            if self._writer is None:
                self._writer = ThreadPoolExecutor(max_workers=1,
                                                  thread_name_prefix="record-writer")
            future = self._writer.submit(self._write_capture, test_id, snapshot, target,
                                         relative)
            self._writing[test_id] = future
        return future

    def _write_capture(self, test_id: str, capture: Capture, target: Path,
                       relative: str) -> dict:
        try:
            sha256 = capture.save(target)
        except OSError as exc:
            with self._lock:
                self.write_error = self.write_error or RecordWriteError(target, exc)
            raise RecordWriteError(target, exc) from exc
        info = {"file": relative, "sha256": sha256, "n_samples": len(capture),
                "sample_rate_hz": to_jsonable(capture.meta.get("sample_rate_hz",
                                                               _rate_from_time(capture)))}
        with self._lock:
            self._apply({"event": "capture", "capture": {"test_id": test_id, **info}})
        return info

    def capture_written(self, test_id: str) -> dict:
        """Wait for the capture of ``test_id`` started by :meth:`save_capture_later`; its dict,
        or its RecordWriteError raised."""
        with self._lock:
            future = self._writing.get(test_id)
        if future is None:
            raise HilError(f"record: no capture of test {test_id!r} is being written")
        return future.result()

    def capture_fault(self, test_id: str) -> "RecordWriteError | None":
        """The storage fault of the capture of ``test_id`` (waiting for its write), or None:
        none, not written in the background, or written."""
        with self._lock:
            future = self._writing.get(test_id)
        if future is None:
            return None
        error = future.exception()
        return error if isinstance(error, RecordWriteError) else None

    def add_test(self, entry: dict) -> dict:
        """Append one test's entry (one journal line).

        ``entry`` needs ``test_id`` and ``outcome`` (one of :data:`OUTCOMES`); the other keys of
        the schema default to null/empty. A capture saved for this ``test_id`` and not named in
        ``entry['capture']`` is attached. Sub-dicts are stored as given (numpy values
        converted). Returns the stored entry.
        """
        if not isinstance(entry, dict):
            raise InputError(f"record: a test entry must be a dict, got {type(entry).__name__}")
        _check_keys(entry, _TEST_KEYS, "test entry")
        test_id = entry.get("test_id")
        safe_test_name(test_id)  # validates
        _check_fields(test_id, {"outcome": entry.get("outcome")} | entry)
        self.capture_fault(test_id)     # waits: the capture's event precedes the entry
        with self._lock:
            self._require_running()
            if self.test(test_id) is not None:
                raise HilError(f"record: test {test_id!r} is already recorded")
            stored = {key: None for key in _TEST_KEYS} | {"notes": []}
            stored |= to_jsonable(entry)
            stored["finished_utc"] = stored["finished_utc"] or utc_now()
            self._apply({"event": "test", "entry": stored})
        return self.test(test_id)

    def update_test(self, test_id: str, **fields: Any) -> dict:
        """Change fields of a recorded entry (``outcome``, ``phase``, ``message``, ``kind``,
        ``requirements``, ``checks``, ``notes``, ``finished_utc``, ``error``): e.g. a user
        assertion after ``measure()`` failed the test that the measurement had recorded."""
        _check_keys(fields, _UPDATABLE_KEYS, "updatable test field")
        _check_fields(test_id, fields)
        with self._lock:
            self._require_running()
            if self.test(test_id) is None:
                raise HilError(f"record: test {test_id!r} is not recorded; add it first")
            self._apply({"event": "update", "test_id": test_id, "fields": to_jsonable(fields)})
        return self.test(test_id)

    def finish(self, status: str = "complete") -> None:
        """Close the record with one of :data:`FINAL_STATUSES`: write the whole ``record.json``
        once, seal it (``record.sha256``), remove the journal."""
        if status not in FINAL_STATUSES:
            raise InputError(f"record: finish status = {status!r}; allowed: "
                             f"{', '.join(FINAL_STATUSES)}")
        from hil import seal

        with self._lock:
            self._require_running()
            self._closing = True                # no capture may start from here on
            writer, self._writer = self._writer, None
        if writer is not None:      # outside the lock: a queued write takes it to journal itself
            writer.shutdown(wait=True)
        with self._lock:
            self._require_running()
            try:
                key, unsigned = seal.station_key(), None
            except seal.StationKeyError as exc:
                key, unsigned = None, str(exc)
            self.data["seal"] = (seal.seal_section(key, self._chain) if key is not None
                                 else {"unsigned_reason": unsigned})
            self.data["status"] = status
            self.data["finished_utc"] = utc_now()
            target = self.path / RECORD_FILE
            try:
                self._close_journal()
                raw = _write_json(target, self.data)
                digest = hashlib.sha256(raw).hexdigest()
                target = self.path / SEAL_FILE
                atomic_write_bytes(target, f"{digest}  {RECORD_FILE}\n".encode())
                if key is not None:
                    target = self.path / seal.SIG_FILE
                    seal.write_seal(self.path, self.record_id, digest, self._chain, key,
                                    atomic_write_bytes)
            except OSError as exc:
                # not closed: in memory as on disk (header + journal), status running
                self.data.update(status="running", finished_utc=None)
                self.data.pop("seal", None)
                self._closing = False
                self.write_error = self.write_error or RecordWriteError(target, exc)
                raise RecordWriteError(target, exc) from exc
            try:        # a journal left beside a finished record.json is never replayed
                (self.path / JOURNAL_FILE).unlink(missing_ok=True)
            except OSError:
                pass

    def verify_captures(self) -> list[str]:
        """Problems with the capture files the record names (missing, altered, outside)."""
        return verify_captures(self.path, self.data)

    # ------------------------------------------------------------------ internals
    def _require_running(self) -> None:
        if self.data["status"] != "running":
            raise HilError(f"record {self.record_id}: already finished "
                           f"({self.data['status']}); it cannot be changed")

    def _apply(self, event: dict) -> None:
        """Append ``event`` to the journal (flushed and fsynced, chained to the line before),
        then apply it in memory."""
        if self.write_error is not None:      # journal abandoned: finish() writes it all
            apply_event(self.data, event)
            return
        try:
            if self._chain is None:
                self._chain = _journal_tail(self.path)
            chain = chain_hash(self._chain, event)
            line = json.dumps(event | {"chain": chain}, allow_nan=False,
                              separators=(",", ":")) + "\n"
            if self._journal is None:
                self._journal = open(self.path / JOURNAL_FILE, "a", encoding="utf-8")
            self._journal.write(line)
            self._journal.flush()
            os.fsync(self._journal.fileno())
        except OSError as exc:
            self.write_error = RecordWriteError(self.path / JOURNAL_FILE, exc)
            apply_event(self.data, event)
            try:
                self._close_journal()
            except OSError:
                pass
            raise self.write_error from exc
        self._chain = chain
        apply_event(self.data, event)

    def _close_journal(self) -> None:
        journal, self._journal = self._journal, None
        if journal is not None:
            journal.close()


def chain_hash(previous: str, event: dict) -> str:
    """SHA-256 (hex) of the previous journal line's chain and one event (without its chain)."""
    body = json.dumps({k: v for k, v in event.items() if k != "chain"}, allow_nan=False,
                      separators=(",", ":"))
    return hashlib.sha256(f"{previous}\n{body}".encode("utf-8")).hexdigest()


def _journal_tail(folder: Path) -> str:
    """The chain to continue from: the last complete journal line's, else the header's hash."""
    try:
        lines = (folder / JOURNAL_FILE).read_text(encoding="utf-8").split("\n")[:-1]
    except FileNotFoundError:
        lines = []
    for line in reversed(lines):
        try:
            return str(json.loads(line)["chain"])
        except (json.JSONDecodeError, KeyError, TypeError):
            continue
    return _sha256_file(folder / RECORD_FILE)


def apply_event(data: dict, event: dict) -> None:
    """Apply one journal event to a record dict (the writer and :func:`load_record` share it)."""
    kind = event.get("event")
    if kind == "capture":
        data["pending_captures"].append(event["capture"])
    elif kind == "test":
        stored = dict(event["entry"])
        pending = data["pending_captures"]
        for item in [p for p in pending if p.get("test_id") == stored["test_id"]]:
            pending.remove(item)
            if stored.get("capture") is None:
                stored["capture"] = {k: v for k, v in item.items() if k != "test_id"}
        data["tests"].append(stored)
    elif kind == "update":
        entry = next(t for t in data["tests"] if t["test_id"] == event["test_id"])
        entry.update(event["fields"])
    elif kind == "section":
        data[event["name"]] = event["data"]
    elif kind == "override":
        data["calibration_overrides"].append(event["override"])
    elif kind == "decision_rule":
        data["decision_rule"] = event["rule"]
    else:
        raise InputError(f"record journal: unknown event {kind!r}")


def _check_keys(entry: dict, allowed: tuple[str, ...], what: str) -> None:
    unknown = sorted(set(entry) - set(allowed))
    if unknown:
        raise InputError(f"record: unknown {what} key(s) {unknown}; allowed: "
                         f"{', '.join(allowed)}")


def _check_fields(test_id: str, fields: dict) -> None:
    for key, allowed in (("outcome", OUTCOMES), ("kind", KINDS), ("phase", PHASES)):
        if key in fields and not (fields[key] is None and key != "outcome") \
                and fields[key] not in allowed:
            raise InputError(f"record: test {test_id!r} {key} = {fields[key]!r}; allowed: "
                             f"{', '.join(allowed)}")


def _check_section_name(name: str) -> None:
    if not isinstance(name, str) or not re.fullmatch(r"[a-z][a-z0-9_]*", name) \
            or name in _RESERVED:
        raise InputError(f"record: section name {name!r} must be a lower-case identifier and "
                         f"not one of {', '.join(_RESERVED)}")


def _write_json(path: Path, data: dict) -> bytes:
    raw = (json.dumps(data, indent=1, allow_nan=False) + "\n").encode("utf-8")
    atomic_write_bytes(path, raw)
    return raw


# ---------------------------------------------------------------------- reading

def load_record(path: str | Path) -> dict:
    """Read and check a record (folder or ``record.json``), replaying an unfinished run's
    journal: format, status and test entries.

    Capture hashes and the seal are checked by :func:`verify_record`, not here (reading every
    capture is slow for long runs).
    """
    folder = _record_folder(path)
    file = folder / RECORD_FILE
    try:
        data = json.loads(file.read_text(encoding="utf-8"))
    except OSError as exc:
        raise InputError(f"record {str(folder)!r}: cannot read {RECORD_FILE}: "
                         f"{exc.strerror}") from None
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InputError(f"record {str(folder)!r}: {RECORD_FILE} is not valid JSON "
                         f"({exc})") from None
    if not isinstance(data, dict) or data.get("format") not in READABLE_FORMATS:
        found = data.get("format") if isinstance(data, dict) else type(data).__name__
        raise InputError(f"record {str(folder)!r}: format = {found!r}; expected {FORMAT!r}")
    for key in ("record_id", "created_utc", "status", "software", "bench", "instruments",
                "tests"):
        if key not in data:
            raise InputError(f"record {str(folder)!r}: {RECORD_FILE} lacks {key!r}")
    data.setdefault("pending_captures", [])
    data.setdefault("calibration_overrides", [])
    data.setdefault("decision_rule", {})
    if data["status"] == "running":
        _replay_journal(folder, data)
    if data["status"] not in STATUSES:
        raise InputError(f"record {str(folder)!r}: status = {data['status']!r}; allowed: "
                         f"{', '.join(STATUSES)}")
    if not isinstance(data["tests"], list):
        raise InputError(f"record {str(folder)!r}: tests must be a list")
    for index, test in enumerate(data["tests"]):
        if not isinstance(test, dict) or "test_id" not in test or \
                test.get("outcome") not in OUTCOMES:
            raise InputError(f"record {str(folder)!r}: tests[{index}] needs a test_id and an "
                             f"outcome in {OUTCOMES}")
    return data


def _replay_journal(folder: Path, data: dict) -> None:
    """Apply every complete line of an unfinished run's journal (a torn last line is dropped:
    the process died while writing it)."""
    try:
        text = (folder / JOURNAL_FILE).read_text(encoding="utf-8")
    except FileNotFoundError:
        return
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"record {str(folder)!r}: cannot read {JOURNAL_FILE}: {exc}") from None
    lines = text.split("\n")
    chain, problems, chained = _sha256_file(folder / RECORD_FILE), [], False
    for number, line in enumerate(lines[:-1], start=1):   # the last piece has no newline
        try:
            event = json.loads(line)
            apply_event(data, event)
        except (json.JSONDecodeError, KeyError, StopIteration, TypeError, AttributeError) as exc:
            raise InputError(f"record {str(folder)!r}: {JOURNAL_FILE} line {number} is damaged "
                             f"({type(exc).__name__})") from None
        expected = chain_hash(chain, event)
        chained = chained or "chain" in event
        if event.get("chain") != expected:
            problems.append(f"{JOURNAL_FILE} line {number} does not match its hash chain: the "
                            f"line" + (f" or the header {RECORD_FILE}" if number == 1 else "")
                            + " was changed after it was written")
        chain = str(event.get("chain", expected))
    if problems and chained:        # a journal without any chain: written before chaining
        data["journal_problems"] = problems


def verify_record(folder: str | Path, data: dict | None = None,
                  trusted: dict[str, str] | None = None) -> list[str]:
    """Every integrity problem of a record: its seal (a finished record's ``record.json`` must
    hash to ``record.sha256`` and carry a valid signature by a trusted key, :mod:`hil.seal`)
    and every capture it names (:func:`verify_captures`). A record sealed before signing has no
    signature problem here (:func:`seal_check` says "unsigned")."""
    folder = _record_folder(folder)
    data = data if data is not None else load_record(folder)
    return (list(data.get("journal_problems") or []) + verify_seal(folder, data, trusted)
            + verify_captures(folder, data))


def verify_seal(folder: str | Path, data: dict, trusted: dict[str, str] | None = None
                ) -> list[str]:
    """Problems with the seal of a finished record (none for a running or format-1 record):
    the SHA-256 of ``record.sha256`` and the signature of ``record.sig``."""
    folder = _record_folder(folder)
    if data.get("status") == "running" or data.get("format") != FORMAT:
        return []
    problems = []
    try:
        expected = (folder / SEAL_FILE).read_text(encoding="ascii").split()[0]
    except (OSError, UnicodeDecodeError, IndexError):
        problems.append(f"{RECORD_FILE} is not sealed: {SEAL_FILE} is missing or unreadable")
        expected = None
    digest = _sha256_file(folder / RECORD_FILE)
    if expected is not None and digest != expected:
        problems.append(f"{RECORD_FILE} has SHA-256 {digest}, its seal {SEAL_FILE} says "
                        f"{expected}: the record was changed after the run finished")
    return problems + seal_check(folder, data, trusted).problems


def seal_check(folder: str | Path, data: dict, trusted: dict[str, str] | None = None):
    """The signature state of a finished record (:class:`hil.seal.SealCheck`); None for a
    running or format-1 record (nothing is sealed)."""
    from hil.seal import check_seal

    folder = _record_folder(folder)
    if data.get("status") == "running" or data.get("format") != FORMAT:
        return None
    return check_seal(folder, data, _sha256_file(folder / RECORD_FILE), trusted)


def verify_captures(folder: str | Path, data: dict | None = None) -> list[str]:
    """Check every capture the record names: inside ``captures/``, present, SHA-256 equal."""
    folder = _record_folder(folder)
    data = data if data is not None else load_record(folder)
    problems = []
    named = [(test["test_id"], test.get("capture")) for test in data["tests"]]
    named += [(item.get("test_id"), item) for item in data.get("pending_captures", [])]
    for test_id, capture in named:
        if not capture:
            continue
        relative = capture.get("file")
        if not isinstance(relative, str):
            problems.append(f"test {test_id!r}: capture has no file name")
            continue
        target = capture_path(folder, relative)
        if target is None:
            problems.append(f"test {test_id!r}: capture path {relative!r} is outside "
                            f"{CAPTURE_DIR}/")
            continue
        if not target.is_file():
            problems.append(f"test {test_id!r}: capture {relative} is missing")
            continue
        digest = _sha256_file(target)
        if digest != capture.get("sha256"):
            problems.append(f"test {test_id!r}: capture {relative} has SHA-256 {digest}, the "
                            f"record says {capture.get('sha256')}")
    return problems


def capture_path(folder: str | Path, relative: str | None) -> Path | None:
    """The file a record's capture entry names, or None if it points outside ``captures/``."""
    if not isinstance(relative, str) or not relative:
        return None
    root = (Path(folder) / CAPTURE_DIR).resolve()
    target = (Path(folder) / relative).resolve()
    return target if target.is_relative_to(root) and target != root else None


def _record_folder(path: str | Path) -> Path:
    path = Path(path)
    return path.parent if path.name == RECORD_FILE else path


def _sha256_file(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _rate_from_time(capture: Capture) -> float | None:
    if "time_s" not in capture or len(capture) < 2:
        return None
    step = float(np.median(np.diff(capture["time_s"])))
    return 1.0 / step if step > 0 else None
