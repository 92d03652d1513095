"""``hil run``: run the test plans (simulated bench by default), record, report.

It is ``pytest testplans`` with the ripple-hil plugin's options filled in: a progress bar per
sweep, a summary table per source at the end, the record folder and the PDF report's path. Test
ids are the same as those of ``pytest testplans`` run from the project folder (same rootdir).
Third-party pytest plugins other than ripple-hil's and pytest-timeout are not loaded (e.g.
hypothesis's costs ~1 s of start-up).

Messages name this command's flags (``--operator``), not the plugin's (``--hil-operator``):
see :data:`RUN_FLAGS`.

Exit codes: 0 no test failed and at least one was judged (a point not determinable here is
not a failure: page 1 then reads NOT STATED for its plan); 1 a test failed or errored; 2 interrupted (Ctrl-C) or bad
input (a usage error, a selection that collects no point, a record folder or report path that
cannot be written: refused before the bench is touched; SIGTERM is an interruption, recorded as
such); 6 the bench could not be
opened (nothing was run); 7 the bench was lost mid-run (the remaining tests are recorded as not
run); 8 the record could not be written mid-run (full disk, read-only or forbidden folder: the
drive made safe, the run stopped, the rest recorded as not run if the record can still be
written); 9 the run finished but judged nothing (every point measured with no verdict or not
determinable here, or only the bench self-check ran); 130 Ctrl-C before pytest's session began (while loading: nothing run, no record).
"""

from __future__ import annotations

import sys
from pathlib import Path

from hil.errors import InputError

AUTO_REPORT = "auto"


def plan_modules() -> dict[str, Path]:
    """Ripple source name → test-plan module file, from the installed ``ripple_hil_testplans``
    package (the testplans/ folder). Found without importing it: pytest marks the packages of
    an installed plugin's distribution for assertion rewriting, and one imported before
    ``pytest.main`` cannot be (a PytestAssertRewriteWarning on every run, issue 22.9)."""
    import importlib.util

    spec = importlib.util.find_spec("ripple_hil_testplans")
    folder = Path(next(iter(spec.submodule_search_locations)))
    return {path.stem.removeprefix("test_"): path for path in sorted(folder.glob("test_*.py"))}


#: pytest plugins (entry-point names) that ``hil run`` keeps; every other one is not loaded.
KEPT_PLUGINS = ("ripple_hil", "timeout")
#: ``hil run`` option → the plugin option it fills in (each also accepted as ``--hil-...``).
PLUGIN_OPTIONS = {"operator": "--hil-operator", "results_db": "--hil-results-db",
                  "dut_serial": "--hil-dut-serial",
                  "dut_serial_override": "--hil-dut-serial-override",
                  "allow_expired_calibration": "--hil-allow-expired-calibration",
                  "customer": "--hil-customer", "authorizer": "--hil-authorizer",
                  "authorizer_function": "--hil-authorizer-function",
                  "item_received": "--hil-item-received", "environment": "--hil-environment"}
#: Each plugin option → the ``hil run`` flag that fills it in: what messages printed during a
#: ``hil run`` name (it passes ``--hil-flag-names hil-run``; pytest users see ``--hil-*``).
RUN_FLAGS = {"--hil-bench": "--bench", "--hil-record": "--record-dir", "--hil-report": "--report",
             "--hil-seed": "--seed", "--hil-sim-defect": "--sim-defect",
             "--hil-requirements": "--requirements",
             **{option: "--" + name.replace("_", "-") for name, option in PLUGIN_OPTIONS.items()}}


def register(subparsers) -> None:
    parser = subparsers.add_parser("run", help="run the test plans, record the run, write the report",
                                   description=__doc__.split("\n\n")[0].replace("``", ""),
                                   epilog=__doc__.split("\n\n")[-1])
    parser.add_argument("--bench", metavar="FILE", help="bench file (default: simulated bench)")
    parser.add_argument("--source", action="append", metavar="NAME",
                        help="run only this source's plan (repeatable); default: all")
    parser.add_argument("--record-dir", metavar="DIR", default="records",
                        help="folder in which the run record is created (default: records)")
    parser.add_argument("-o", "--report", metavar="FILE.pdf", default=AUTO_REPORT,
                        help="PDF report path (default: report.pdf in the record folder)")
    parser.add_argument("--no-report", action="store_true", help="do not write the PDF report")
    parser.add_argument("--seed", type=seed_value, default=0,
                        help="simulated bench seed, an integer >= 0 (default 0)")
    parser.add_argument("--requirements", metavar="SPEC.toml",
                        help="the user's ripple requirements, judged on every point they apply "
                             "to (e.g. hil/examples/requirements.toml)")
    parser.add_argument("--operator", metavar="NAME",
                        help="who runs the bench (page 1 of the report; needed with "
                             "--allow-expired-calibration)")
    parser.add_argument("--allow-expired-calibration", metavar="REASON",
                        help="run although an instrument is past its calibration due date "
                             "(recorded with --operator, stated on page 1)")
    parser.add_argument("--results-db", metavar="URL",
                        help="results database the sealed record is indexed in (SQLAlchemy URL "
                             "or 'off'; default: RIPPLE_HIL_RESULTS_DB, the bench file's [results] "
                             "url, else results.sqlite in the record folder's parent)")
    parser.add_argument("--dut-serial", metavar="SN",
                        help="serial number of the unit under test (recorded and indexed; "
                             "checked against the drive's 0x1018 serial number, see "
                             "[drive] serial_label, before the drive is driven)")
    parser.add_argument("--dut-serial-override", metavar="REASON",
                        help="run although --dut-serial is not the drive's serial (the reason "
                             "is recorded and stated on page 1)")
    parser.add_argument("--customer", metavar="TEXT", help="customer named on the report")
    parser.add_argument("--authorizer", metavar="NAME",
                        help="person authorizing the report (default: the bench file's [lab])")
    parser.add_argument("--authorizer-function", metavar="TEXT",
                        help="function of the person authorizing the report")
    parser.add_argument("--item-received", metavar="YYYY-MM-DD",
                        help="date the item tested was received")
    parser.add_argument("--environment", metavar="TEXT",
                        help="environmental conditions, e.g. '23 °C, 45 %% RH'")
    parser.add_argument("--sim-defect", action="append", metavar="KEY=VALUE", default=[],
                        help="test-only defect of the simulated drive (repeatable), e.g. "
                             "hidden_ia_offset_a=0.5; stated on page 1")
    parser.add_argument("-x", "--exitfirst", action="store_true", help="stop at the first failure")
    parser.add_argument("pytest_args", nargs="*", metavar="PYTEST_ARG",
                        help="extra pytest arguments (after --)")
    parser.set_defaults(func=run)


def seed_value(text: str) -> int:
    """argparse type of a seed: an integer >= 0 (numpy's SeedSequence refuses negatives)."""
    import argparse

    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"{value} is negative; allowed: an integer >= 0")
    return value


#: The plan that verifies the bench; ``--source`` always runs it too (a failed self-check voids
#: the other verdicts, an unverified bench has no basis for them).
SELF_CHECK = "self_check"


def build_pytest_args(args) -> list[str]:
    modules = plan_modules()
    selected = args.source or list(modules)
    unknown = [name for name in selected if name not in modules]
    if unknown:
        raise InputError(f"--source {', '.join(unknown)} is not a test plan; allowed: "
                         f"{', '.join(modules)}")
    if SELF_CHECK in modules and SELF_CHECK not in selected:
        selected = [SELF_CHECK, *selected]
    _check_report_path(args)
    _check_record_dir(args)
    if args.bench:
        from hil.config import load_bench

        load_bench(args.bench)   # a bad bench file is a one-line error here, before pytest starts
    pytest_args = [str(modules[name]) for name in selected]
    pytest_args += ["-q", "-p", "no:cacheprovider", *unrelated_plugins(), "--hil-progress",
                    "--hil-flag-names", "hil-run",
                    "--hil-seed", str(args.seed), "--hil-record", args.record_dir,
                    "--rootdir", str(modules[selected[0]].parent.parent)]
    for name, option in PLUGIN_OPTIONS.items():
        if getattr(args, name, None):
            pytest_args += [option, getattr(args, name)]
    for defect in args.sim_defect:
        pytest_args += ["--hil-sim-defect", defect]
    if args.bench:
        pytest_args += ["--hil-bench", args.bench]
    if not args.no_report:
        pytest_args += ["--hil-report", args.report]
    if args.requirements:
        from hil.requirements import load_requirements

        load_requirements(args.requirements)    # a bad file: one-line error before pytest starts
        pytest_args += ["--hil-requirements", args.requirements]
    if args.exitfirst:
        pytest_args.append("-x")
    return pytest_args + list(args.pytest_args)


def _check_report_path(args) -> None:
    """A report path that cannot be written is refused before the bench opens (never after a
    whole run); an existing file is never overwritten."""
    if args.no_report or args.report == AUTO_REPORT:
        return
    target = Path(args.report)
    if target.exists():
        raise InputError(f"-o {target}: the file exists and a report is never overwritten; "
                         "choose another path (or use hil report --reason for a revision)")
    if not target.parent.is_dir():
        raise InputError(f"-o {target}: folder {target.parent} does not exist")
    _probe(f"-o {target}", target.parent)


def _check_record_dir(args) -> None:
    """A record folder that cannot be written, or a station signing key that cannot be made,
    is refused before the bench opens (exit 2), not found after the first point."""
    from hil.seal import StationKeyError, station_key

    _probe(f"--record-dir {args.record_dir}", Path(args.record_dir))
    try:
        station_key()
    except StationKeyError as exc:
        raise InputError(str(exc)) from None


def _probe(option: str, folder: Path) -> None:
    from hil.record import RecordWriteError, check_writable_folder

    try:
        check_writable_folder(folder)
    except RecordWriteError as exc:
        raise InputError(f"{option}: {exc}") from None


def unrelated_plugins() -> list[str]:
    """``-p no:NAME`` for every installed pytest plugin that a bench run does not need."""
    import importlib.metadata

    names = sorted({ep.name for ep in importlib.metadata.entry_points(group="pytest11")}
                   - set(KEPT_PLUGINS))
    return [arg for name in names for arg in ("-p", f"no:{name}")]


def run(args) -> int:
    import gc
    import signal

    import pytest

    pytest_args = build_pytest_args(args)
    # SIGTERM (a CI timeout, systemd, kill) takes the Ctrl-C path: the bench is made safe and
    # the record closed as interrupted.
    signal.signal(signal.SIGTERM, lambda signum, frame: signal.raise_signal(signal.SIGINT))
    try:
        try:
            code = pytest.main(pytest_args)
        finally:
            gc.unfreeze()           # the plugin froze the run's heap (fixtures/plugin.py)
    except Exception as exc:
        if not isinstance(exc.__context__, KeyboardInterrupt):
            raise
        # pytest's own Ctrl-C report failed after the session finished (pytest 9 computes
        # tb_lineno - 1, and CPython 3.11 gives tb_lineno None for a KeyboardInterrupt raised
        # at an instruction without a line, ~0.1 % of presses): the record is closed; one line.
        print(f"hil run: interrupted (pytest's Ctrl-C report failed: {type(exc).__name__}: "
              f"{exc})", file=sys.stderr)
        return int(pytest.ExitCode.INTERRUPTED)
    if code == pytest.ExitCode.NO_TESTS_COLLECTED:
        print("hil run: no test plan point was collected", file=sys.stderr)
        return 2
    if code == pytest.ExitCode.USAGE_ERROR:       # pytest printed it (e.g. a bad --item-received)
        return 2
    return int(code)
