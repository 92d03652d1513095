"""Fixtures shared by the test folders: a simulated bench over the real stacks, a run record."""

import functools
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest


def _keep_bytecode_caches() -> None:
    """Let this session and every process it starts write Python's and pytest's bytecode caches
    (``__pycache__``), which ``PYTHONDONTWRITEBYTECODE`` (set on some hosts) turns off.

    Without them each of the suite's hundreds of Python processes compiles the project's
    sources again, and each ``hil run`` (a pytest session of its own) rewrites the plans'
    asserts again: ~1 s of CPU per run, and ~10 s of each xdist worker's collection (18 s
    against 8 s). The caches are checked against each source's size and time stamp, so a
    changed file is never read stale; numba's caches already sit in the same folders."""
    sys.dont_write_bytecode = False
    os.environ.pop("PYTHONDONTWRITEBYTECODE", None)


def _no_spinning_thread_pools() -> None:
    """Idle thread-pool threads sleep instead of spinning, in this session's workers and every
    process they start (each variable only where not set already): OpenBLAS's
    (``OPENBLAS_THREAD_TIMEOUT=4``: 2^4 cycles, not 2^28) and GNU OpenMP's, under numba's
    parallel batch kernel (``OMP_WAIT_POLICY=PASSIVE``).

    The suite keeps both cores busy with its own processes; a pool thread spinning after each
    call on the small matrices the analyses fit took a core from another test's process (a
    least-squares fit of 4000 x 12, 300 times: 1.2 s of CPU on an idle machine and 9-18 s
    with the cores busy, where it also took 16-24 s of wall time; 0.3 s of CPU and ~1 s with
    sleeping threads). The pools keep their threads and the arithmetic stays as it was; only
    their waiting changes. The libraries read the variables when they load, so the workers
    (started after this) and their subprocesses get them."""
    os.environ.setdefault("OPENBLAS_THREAD_TIMEOUT", "4")
    os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")


_keep_bytecode_caches()
_no_spinning_thread_pools()

from hil.bench import Bench  # noqa: E402  (after the bytecode setting: these imports cache)
from hil.config import default_sim_bench  # noqa: E402
from hil.record import RunRecord  # noqa: E402


@pytest.fixture(autouse=True)
def results_database_off(monkeypatch):
    """Runs that tests make index nothing (``RIPPLE_HIL_RESULTS_DB=off``, inherited by their
    subprocesses): the results database is a sink with tests of its own (``tests/results``,
    which override this fixture), and a ``results.sqlite`` beside every test's records would
    only be noise in folders the tests list."""
    monkeypatch.setenv("RIPPLE_HIL_RESULTS_DB", "off")


@pytest.fixture
def sim_bench():
    """A freshly opened simulated bench (CANopen on a virtual bus, Modbus TCP, serial pty)."""
    bench = Bench.open(default_sim_bench(), seed=3)
    yield bench
    bench.close()


@pytest.fixture
def run_record(tmp_path, sim_bench):
    record = RunRecord.create(tmp_path, sim_bench.config, sim_bench.identities())
    yield record
    if record.status == "running":
        record.finish("complete")


#: Folders whose conftest gives a costly session-scoped fixture: a PostgreSQL server and a
#: default run's records (results), Dask clusters (campaign), the twin's compiled engine loaded
#: before the first capture (drivers_daq, drivers_transducer). Each runs whole on one worker.
SHARED_SESSION_FOLDERS = ("tests/campaign", "tests/drivers_daq", "tests/drivers_transducer",
                          "tests/results")
#: Folders of whole runs, benches and independent simulators: their tests start first, so the
#: quick unit tests fill the workers' tails.
LONG_RUNNING_FOLDERS = ("tests/independent", "tests/integration", "tests/mutations",
                        "tests/results", "tests/campaign", "tests/station", "tests/validity",
                        "tests/characterisation", "tests/sim", "tests/plans", "tests/reports")
#: The longest work units, longest first (approximate wall seconds on the 2-core machine):
#: they start before every other unit, so none is handed out late and left running alone at
#: the end.
LONGEST_FIRST = (
    # ~110 s: motulator's carrier comparison, 1.2 simulated seconds
    "tests/independent/test_foreign_bench.py::test_foreign_bench_self_check_runs_as_a_user_would",
    "tests/results",                                   # ~90 s: six whole runs, PostgreSQL
    "tests/campaign",                                  # ~70 s: Dask clusters
    "tests/independent/test_motulator_diagnosis.py",   # ~65 s: 12 motulator points
    "tests/integration/test_long_lived_sim_bench.py",  # ~45 s: whole runs on one sim-bench
    "tests/validity/test_validity_study.py",           # ~25 s: two whole runs
)
_SHARED_FIXTURES = re.compile(r"scope\s*=\s*[\"'](module|class|package)[\"']|def setup_module")


def _in(folders: tuple[str, ...], scope: str) -> bool:
    """``scope`` (a node id, a file or a folder) lies in one of ``folders`` (node ids, files or
    folders)."""
    return any(scope == f or scope.startswith((f + "/", f + "::")) for f in folders)


def _start_order(scope: str) -> tuple[int, bool]:
    """Sort key of a work unit: LONGEST_FIRST in its order, then the LONG_RUNNING_FOLDERS, then
    the rest (a stable sort keeps xdist's own order, most tests first, within each group)."""
    longest = next((i for i, unit in enumerate(LONGEST_FIRST) if _in((unit,), scope)),
                   len(LONGEST_FIRST))
    return longest, not _in(LONG_RUNNING_FOLDERS, scope)


@functools.lru_cache(maxsize=None)
def _file_shares_fixtures(rootdir: Path, path: str) -> bool:
    return bool(_SHARED_FIXTURES.search((rootdir / path).read_text(encoding="utf-8")))


_WARM_UP = pytest.StashKey[subprocess.Popen]()
#: The longest a cold warm-up may take (~45 s on an idle machine) before the tests start anyway.
WARM_UP_TIMEOUT_S = 600.0


def _start_warm_up(config) -> None:
    """Build numba's on-disk caches of every kernel a run uses (``python -m hil.warmup``, which
    ``make`` runs at install) while the workers collect. With the caches built it only loads
    them (~3 s, hidden behind the collection); on a cold cache (a new checkout, an edited
    engine) the first tests' processes would otherwise each compile the same kernels at the
    same time (~30 s of CPU each; the campaign's twin fixture took 65 s on a cold cache, 2 s on
    a warm one)."""
    config.stash[_WARM_UP] = subprocess.Popen([sys.executable, "-m", "hil.warmup"],
                                              stdout=subprocess.DEVNULL,
                                              stderr=subprocess.DEVNULL)


def _finish_warm_up(config, timeout_s: float = WARM_UP_TIMEOUT_S) -> None:
    """Wait for the warm-up; stop it after ``timeout_s`` (the tests then compile what they
    need themselves)."""
    process = config.stash.get(_WARM_UP, None)
    if process is None:
        return
    try:
        process.wait(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        process.kill()
        process.wait()


@pytest.hookimpl(optionalhook=True)                   # a hook of pytest-xdist's
def pytest_xdist_make_scheduler(config, log):
    """``make test``'s pytest-xdist scheduling: a folder of SHARED_SESSION_FOLDERS goes whole to
    one worker, a file with module-scoped fixtures whole to one worker (each is built once), any
    other test to whichever worker is free; the LONGEST_FIRST units start first, then the
    LONG_RUNNING_FOLDERS, each group in xdist's own order (most tests first). The first tests
    are handed out once numba's caches are built (``_start_warm_up``)."""
    from xdist.scheduler import LoadScopeScheduling

    rootdir = config.rootpath
    _start_warm_up(config)          # the workers are collecting meanwhile

    class FolderFileOrTest(LoadScopeScheduling):
        def schedule(self) -> None:
            _finish_warm_up(config)
            super().schedule()

        def _split_scope(self, nodeid: str) -> str:
            path = nodeid.split("::")[0]
            folder = next((f for f in SHARED_SESSION_FOLDERS if _in((f,), path)), None)
            if folder:
                return folder
            return path if _file_shares_fixtures(rootdir, path) else nodeid

        def _assign_work_unit(self, node) -> None:
            # the work queue (scope -> node ids) is complete before the first assignment; only
            # its order changes here (the workers' collections must stay as they were collected:
            # xdist names a test to a worker by its index in them)
            if not getattr(self, "_long_first", False):
                self._long_first = True
                units = sorted(self.workqueue.items(), key=lambda unit: _start_order(unit[0]))
                self.workqueue.clear()
                self.workqueue.update(units)
            super()._assign_work_unit(node)

    return FolderFileOrTest(config, log)


_WORKER_TMP = pytest.StashKey[str]()


def pytest_configure(config):
    """Each pytest-xdist worker gets a temporary folder of its own (``TMPDIR``, inherited by the
    runs it starts): the station's one-run-per-bench lock lives there, and two workers' stations,
    each with its own in-process simulated bench, are two computers, not one bench twice."""
    worker = os.environ.get("PYTEST_XDIST_WORKER")
    if worker:
        folder = tempfile.mkdtemp(prefix=f"ripple-hil-tests-{worker}-")
        os.chmod(folder, 0o755)     # the test PostgreSQL server runs as the postgres user
        config.stash[_WORKER_TMP] = folder
        os.environ["TMPDIR"] = folder
        tempfile.tempdir = None


def pytest_unconfigure(config):
    _finish_warm_up(config, timeout_s=0.0)      # a session stopped before its first test
    folder = config.stash.get(_WORKER_TMP, None)
    if folder:
        shutil.rmtree(folder, ignore_errors=True)

