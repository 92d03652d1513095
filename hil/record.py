"""Run records: one folder per run, ``record.json`` plus ``captures/<test-id>.npz``.

The record is written test by test and every write is atomic (temp file + rename), so a crash or
Ctrl-C keeps each finished test. A test's raw capture is saved *before* it is analysed
(:meth:`RunRecord.save_capture`); until its test entry is added, the capture is listed under
``pending_captures`` so its SHA-256 is never lost. ``status`` is ``running`` until
:meth:`RunRecord.finish` sets ``complete``, ``interrupted`` or ``failed``; a record left
``running`` was cut short. Schema: ``"format": "ripple-hil-record/1"`` (see the fields below).
"""

from __future__ import annotations

import hashlib
import importlib.metadata
import json
import math
import platform
import re
import secrets
import subprocess
import threading
from datetime import date, datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np

import hil
from hil.capture import Capture, atomic_write_bytes
from hil.config import BenchConfig
from hil.errors import HilError, InputError

FORMAT = "ripple-hil-record/1"
RECORD_FILE = "record.json"
CAPTURE_DIR = "captures"
STATUSES = ("running", "complete", "interrupted", "failed")
FINAL_STATUSES = STATUSES[1:]
OUTCOMES = ("passed", "failed", "error", "skipped")
#: Distributions whose versions every record lists.
PACKAGES = ("numpy", "scipy", "numba", "python-can", "canopen", "pymodbus", "pyserial",
            "matplotlib", "fpdf2", "pytest")
_TEST_KEYS = ("test_id", "nodeid", "source", "started_utc", "finished_utc", "outcome",
              "injection", "operating_point", "capture", "measured", "prediction",
              "uncertainty", "verdict", "notes", "error")
_INSTRUMENT_KEYS = ("role", "model", "serial_number", "range", "accuracy_class", "resolution",
                    "calibration_date", "calibration_due")


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

    # ------------------------------------------------------------------ create / open
    @classmethod
    def create(cls, root: str | Path, bench: BenchConfig, instruments: list[dict], *,
               decision_rule: dict | None = None, name: str | None = None) -> "RunRecord":
        """Start a record in ``root/<name or record_id>`` and write its first ``record.json``.

        ``instruments``: identities as queried from the instruments (see
        :func:`instrument_table`). ``decision_rule`` may also be set later, before the first test.
        """
        record_id = new_record_id()
        folder = Path(root) / (safe_test_name(name) if name else record_id)
        if (folder / RECORD_FILE).exists():
            raise InputError(f"record folder {str(folder)!r} already holds a {RECORD_FILE}")
        (folder / CAPTURE_DIR).mkdir(parents=True, exist_ok=True)
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
            "tests": [],
            "pending_captures": [],
        }
        record = cls(folder, data)
        record._write()
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

    # ------------------------------------------------------------------ writing
    def set_decision_rule(self, rule: dict) -> None:
        """Store the decision rule; refused once a test is recorded (agreed before measuring)."""
        with self._lock:
            self._require_running()
            if self.data["tests"]:
                raise HilError("record: the decision rule must be agreed before the first test "
                               f"is recorded; {len(self.data['tests'])} test(s) already are")
            self.data["decision_rule"] = to_jsonable(rule)
            self._write()

    def add_calibration_override(self, role: str, serial_number: str, due: str | date,
                                 reason: str, by: str) -> None:
        """Record that an instrument past its calibration due date was used, why and by whom."""
        if not reason or not by:
            raise InputError("record: a calibration override needs a reason and a name (by)")
        with self._lock:
            self._require_running()
            self.data["calibration_overrides"].append(to_jsonable(
                {"role": role, "serial_number": serial_number, "due": due, "reason": reason,
                 "by": by}))
            self._write()

    def save_capture(self, test_id: str, capture: Capture) -> dict:
        """Write the raw capture of ``test_id`` to ``captures/`` now, before any analysis.

        Returns ``{file, sha256, n_samples, sample_rate_hz}`` (``file`` relative to the record
        folder) and lists it under ``pending_captures`` until the test entry is added.
        """
        name = safe_test_name(test_id)
        relative = f"{CAPTURE_DIR}/{name}.npz"
        target = self.path / relative
        with self._lock:
            self._require_running()
            if target.exists():
                raise HilError(f"record: a capture for test {test_id!r} already exists "
                               f"({relative}); test ids must be unique within a run")
            sha256 = capture.save(target)
            info = {"file": relative, "sha256": sha256, "n_samples": len(capture),
                    "sample_rate_hz": to_jsonable(capture.meta.get("sample_rate_hz",
                                                                   _rate_from_time(capture)))}
            self.data["pending_captures"].append({"test_id": test_id, **info})
            self._write()
        return info

    def add_test(self, entry: dict) -> dict:
        """Append one test's entry and rewrite ``record.json`` atomically.

        ``entry`` needs ``test_id`` and ``outcome`` (passed | failed | error | skipped); the
        other keys of the schema default to null/empty. A capture saved for this ``test_id``
        and not named in ``entry['capture']`` is attached. Sub-dicts are stored as given
        (numpy values converted). Returns the stored entry.
        """
        if not isinstance(entry, dict):
            raise InputError(f"record: a test entry must be a dict, got {type(entry).__name__}")
        unknown = sorted(set(entry) - set(_TEST_KEYS))
        if unknown:
            raise InputError(f"record: unknown test entry key(s) {unknown}; allowed: "
                             f"{', '.join(_TEST_KEYS)}")
        test_id = entry.get("test_id")
        safe_test_name(test_id)  # validates
        if entry.get("outcome") not in OUTCOMES:
            raise InputError(f"record: test {test_id!r} outcome = {entry.get('outcome')!r}; "
                             f"allowed: {', '.join(OUTCOMES)}")
        with self._lock:
            self._require_running()
            if any(test["test_id"] == test_id for test in self.data["tests"]):
                raise HilError(f"record: test {test_id!r} is already recorded")
            stored = {key: None for key in _TEST_KEYS} | {"notes": []}
            stored |= to_jsonable(entry)
            stored["finished_utc"] = stored["finished_utc"] or utc_now()
            pending = self.data["pending_captures"]
            for item in [p for p in pending if p["test_id"] == test_id]:
                pending.remove(item)
                if stored["capture"] is None:
                    stored["capture"] = {k: v for k, v in item.items() if k != "test_id"}
            self.data["tests"].append(stored)
            self._write()
        return stored

    def finish(self, status: str = "complete") -> None:
        """Close the record with ``complete``, ``interrupted`` or ``failed``."""
        if status not in FINAL_STATUSES:
            raise InputError(f"record: finish status = {status!r}; allowed: "
                             f"{', '.join(FINAL_STATUSES)}")
        with self._lock:
            self._require_running()
            self.data["status"] = status
            self.data["finished_utc"] = utc_now()
            self._write()

    def verify_captures(self) -> list[str]:
        """Problems with the capture files the record names (missing, altered, outside)."""
        return verify_captures(self.path, self.data)

    def _require_running(self) -> None:
        if self.data["status"] != "running":
            raise HilError(f"record {self.record_id}: already finished "
                           f"({self.data['status']}); it cannot be changed")

    def _write(self) -> None:
        text = json.dumps(self.data, indent=2, allow_nan=False) + "\n"
        atomic_write_bytes(self.path / RECORD_FILE, text.encode("utf-8"))


# ---------------------------------------------------------------------- reading

def load_record(path: str | Path) -> dict:
    """Read and check a record (folder or ``record.json``): format, status and test entries.

    Capture hashes are checked by :func:`verify_captures`, not here (reading every capture is
    slow for long runs).
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
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        found = data.get("format") if isinstance(data, dict) else type(data).__name__
        raise InputError(f"record {str(folder)!r}: format = {found!r}; expected {FORMAT!r}")
    for key in ("record_id", "created_utc", "status", "software", "bench", "instruments",
                "tests"):
        if key not in data:
            raise InputError(f"record {str(folder)!r}: {RECORD_FILE} lacks {key!r}")
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
    data.setdefault("pending_captures", [])
    data.setdefault("calibration_overrides", [])
    data.setdefault("decision_rule", {})
    return data


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
