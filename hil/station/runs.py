"""Start and stop one bench's run: the same ``hil run`` the command line starts, as a child.

Start runs ``python -m hil run --bench FILE --source … --record-dir ROOT`` with the unit's serial
number and the station's answer folder passed to the ripple-hil plugin (``fixtures/operator.py``);
Stop sends that child SIGINT — exactly Ctrl-C at a terminal, so the plugin's interrupt guard
leaves the drive safe and closes the record ``interrupted``. One run per bench at a time: a
second Start is refused with the reason, also when another station process on this machine holds
the same bench (an exclusive ``flock`` on a lock file named after the bench file, inherited by the
child run, so it is held for the run's whole life even if the station dies). A ``hil run``
started by hand at a terminal does not take this lock. The run outlives any browser: it belongs to the station process, not to a page.
"""

from __future__ import annotations

import fcntl
import hashlib
import json
import os
import re
import secrets
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

from hil.station.journal import RecordFollower, find_record

#: A unit serial number: what a barcode scanner types (letters, digits, - _ . / :), ≤ 64 chars.
SERIAL_PATTERN = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._:/-]{0,63}$")
#: Operator answers are plain text lines, this long at most.
MAX_ANSWER_CHARS = 200


class Refused(Exception):
    """A request the station does not carry out; the message says why, in operator words."""


@dataclass
class Run:
    """One child run the station started."""

    unit_serial: str
    sources: list[str]
    token: str
    process: subprocess.Popen
    started_s: float
    answers_dir: Path
    log_path: Path
    record_dir: Path | None = None
    follower: RecordFollower | None = None
    stop_requested_s: float | None = None
    exit_status: int | None = None
    ended_s: float | None = None
    answered: set[str] = field(default_factory=set)

    @property
    def alive(self) -> bool:
        return self.exit_status is None


class RunManager:
    """The station's one bench: at most one child run at a time."""

    def __init__(self, bench_path: str | None, record_root: str | Path,
                 python: str = sys.executable, extra_args: list[str] | None = None,
                 own_plans: dict[str, str] | None = None, requirements: str | None = None,
                 results_db: str | None = None,
                 selection_requirements: dict[frozenset, str] | None = None) -> None:
        self.bench_path = bench_path
        #: ``hil run --requirements`` of every unit, unless the plans picked are a saved
        #: selection with its own (``selection_requirements``: frozenset of plans → file)
        self.requirements = requirements
        self.selection_requirements = dict(selection_requirements or {})
        #: ``hil run --results-db`` of every unit (None: hil run's default rule)
        self.results_db = results_db
        #: Plans of the lab's own (name → pytest file), offered beside the shipped ones.
        self.own_plans = dict(own_plans or {})
        self.record_root = Path(record_root).resolve()
        self.record_root.mkdir(parents=True, exist_ok=True)
        self.python = python
        self.extra_args = list(extra_args or [])
        self.run: Run | None = None
        self._lock = threading.RLock()
        self._bench_lock_file = None
        self.state_dir = Path(tempfile.mkdtemp(prefix="hil-station-"))

    # ------------------------------------------------------------------ start / stop
    def start(self, unit_serial: str, sources: list[str], available: list[str],
              operator: str | None = None) -> Run:
        unit_serial = (unit_serial or "").strip()
        if not SERIAL_PATTERN.match(unit_serial):
            raise Refused("enter the unit's serial number (letters, digits, - _ . / :, at most "
                          "64 characters)")
        unknown = [name for name in sources if name not in available]
        if not sources or unknown:
            raise Refused(f"pick at least one plan; unknown: {', '.join(unknown)}" if unknown
                          else "pick at least one plan")
        with self._lock:
            self.refresh()
            if self.run is not None and self.run.alive:
                raise Refused(f"a run is already going on this bench (unit "
                              f"{self.run.unit_serial}); stop it or wait for its end")
            self._take_bench_lock()
            token = secrets.token_hex(8)
            answers = self.state_dir / f"answers-{token}"
            answers.mkdir()
            log_path = self.state_dir / f"run-{token}.log"
            command = [self.python, "-m", "hil", "run", "--record-dir", str(self.record_root)]
            if self.bench_path:
                command += ["--bench", self.bench_path]
            shipped = [name for name in sources if name not in self.own_plans]
            # hil run without --source runs every shipped plan: with only own plans selected,
            # name the self-check (which hil run runs first anyway)
            for name in shipped or ["self_check"]:
                command += ["--source", name]
            if operator:
                command += ["--operator", operator]
            requirements = self.requirements_for(sources)
            if requirements:
                command += ["--requirements", requirements]
            if self.results_db:
                command += ["--results-db", self.results_db]
            command += ["--dut-serial", unit_serial]     # checked against the drive (hil.dut)
            command += ["--", "--hil-unit-serial", unit_serial, "--hil-station-run", token,
                        "--hil-station-answers", str(answers), *self.extra_args,
                        *[self.own_plans[name] for name in sources if name in self.own_plans]]
            try:
                with open(log_path, "wb") as log:
                    process = subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT,
                                               stdin=subprocess.DEVNULL,
                                               start_new_session=True,
                                               pass_fds=(self._bench_lock_file.fileno(),))
            except OSError as exc:
                self._release_bench_lock()
                raise Refused(f"the run could not be started: {exc}") from None
            self.run = Run(unit_serial=unit_serial, sources=list(sources), token=token,
                           process=process, started_s=time.time(), answers_dir=answers,
                           log_path=log_path)
            return self.run

    def requirements_for(self, sources: list[str]) -> str | None:
        """The requirements file a unit with these plans is judged against: its saved
        selection's when the plans are exactly one, else the station's."""
        return self.selection_requirements.get(frozenset(sources), self.requirements)

    def stop(self) -> Run:
        """Ctrl-C for the child run: SIGINT (the drive is made safe, the record interrupted)."""
        with self._lock:
            self.refresh()
            run = self.run
            if run is None or not run.alive:
                raise Refused("no run is going on")
            if run.stop_requested_s is None:
                run.stop_requested_s = time.time()
            run.process.send_signal(signal.SIGINT)
            return run

    def answer(self, prompt_id: str, value: str) -> None:
        """Hand the operator's answer to the waiting ``operator`` fixture of the child run."""
        with self._lock:
            run = self.run
            if run is None or not run.alive:
                raise Refused("no run is waiting for an answer")
            if not re.match(r"^[A-Za-z0-9_.-]{1,64}$", prompt_id or ""):
                raise Refused("unknown question")
            value = str(value if value is not None else "")
            if len(value) > MAX_ANSWER_CHARS or "\n" in value:
                raise Refused(f"an answer is one line of at most {MAX_ANSWER_CHARS} characters")
            if prompt_id in run.answered:
                raise Refused("this question was already answered")
            self.refresh()
            from hil.station.view import prompts

            waiting = prompts(run.follower.data) if run.follower and run.follower.data else []
            if prompt_id not in [p["key"] for p in waiting]:
                raise Refused("no such question is waiting (an answer is only taken for a "
                              "question the run has asked)")
            target = run.answers_dir / f"{prompt_id}.json"
            tmp = target.with_suffix(".tmp")
            tmp.write_text(json.dumps({"answer": value, "utc": time.time()}), encoding="utf-8")
            os.replace(tmp, target)
            run.answered.add(prompt_id)

    # ------------------------------------------------------------------ follow
    def refresh(self) -> bool:
        """Reap the child when it ended, find and follow its record; True when anything
        changed."""
        with self._lock:
            run = self.run
            if run is None:
                return False
            changed = False
            if run.record_dir is None:
                run.record_dir = find_record(self.record_root, run.token, run.started_s)
                if run.record_dir is not None:
                    run.follower = RecordFollower(run.record_dir)
                    changed = True
            if run.follower is not None:
                changed = run.follower.poll() or changed
            if run.alive and run.process.poll() is not None:
                run.exit_status = run.process.returncode
                run.ended_s = time.time()
                self._release_bench_lock()
                if run.record_dir is None:
                    run.record_dir = find_record(self.record_root, run.token, run.started_s)
                    if run.record_dir is not None:
                        run.follower = RecordFollower(run.record_dir)
                if run.follower is not None:
                    run.follower.poll()
                changed = True
            return changed

    def log_tail(self, lines: int = 3) -> list[str]:
        """The child's last output lines (shown when it ended without a record)."""
        run = self.run
        if run is None:
            return []
        try:
            text = run.log_path.read_text(encoding="utf-8", errors="replace")
        except OSError:
            return []
        return [line for line in text.splitlines() if line.strip()][-lines:]

    def close(self) -> None:
        """At station shutdown: Ctrl-C a run still going, wait for its safe stop."""
        run = self.run
        if run is not None and run.process.poll() is None:
            run.process.send_signal(signal.SIGINT)
            try:
                run.process.wait(timeout=60)
            except subprocess.TimeoutExpired:
                run.process.kill()
        self._release_bench_lock()
        shutil.rmtree(self.state_dir, ignore_errors=True)

    # ------------------------------------------------------------------ bench lock
    def lock_path(self) -> Path:
        """The lock file of this bench (one per bench file, or the simulated bench)."""
        key = str(Path(self.bench_path).resolve()) if self.bench_path else "simulated-bench"
        digest = hashlib.sha256(key.encode()).hexdigest()[:16]
        return Path(tempfile.gettempdir()) / f"hil-station-bench-{digest}.lock"

    def _take_bench_lock(self) -> None:
        handle = open(self.lock_path(), "a+")
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            handle.close()
            raise Refused("another station on this computer is running a unit on this bench; "
                          "one run per bench at a time") from None
        self._bench_lock_file = handle

    def _release_bench_lock(self) -> None:
        """Close this station's handle of the lock. The child run inherited the same open file
        (``pass_fds``), so the bench stays locked until the run itself ends — also when this
        station dies first and a restarted one would otherwise start a second run."""
        if self._bench_lock_file is not None:
            self._bench_lock_file.close()
            self._bench_lock_file = None
