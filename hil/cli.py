"""The ``hil`` command line: one sub-command per module in ``hil.commands``.

Each command module defines ``register(subparsers)``, which adds its parser and sets
``func(args) -> int``. Errors: bad input (including a usage error) prints one line on stderr and
exits 2; an instrument or run failure prints one line and exits 1; Ctrl-C exits 130. ``--json``
output is one JSON object on stdout; with ``--json`` an error is also one JSON object on stdout,
``{"error": {"command", "kind" (usage | input | failed | interrupted), "message",
"exit_status"}}``, beside the one-line message on stderr.

Ctrl-C at any moment once this module is imported — while a command's imports run, while the
parser is built, during the command — prints one line ``hil COMMAND: interrupted`` and exits 130
(``hil run`` itself exits 2 once pytest has started: its documented "interrupted" code). The
module imports nothing heavy at its top (argparse and json are imported when used), so the window
in which Ctrl-C can still hit before :func:`main` runs is the interpreter's own start-up plus a
few statements; a traceback printed there is Python's (``init_import_site``), not this program's.
"""

from __future__ import annotations

import sys

DESCRIPTION = ("ripple-hil: hardware-in-the-loop bench tests of the torque ripple a PMSM drive's "
               "controller adds, judged against the closed-form predictions of Chen, Namuduri "
               "and Mir (IEEE Trans. Ind. Appl. 38(5), 2002).")
EPILOG = ("Run 'hil COMMAND --help' for a command's options. Bad input exits 2 with one line on "
          "stderr, a failed run exits 1; with --json an error is also a JSON object on stdout.")

#: The sub-commands, in the order ``hil --help`` lists them: command name → (module under
#: ``hil.commands``, one-line help). Only the named command's module is imported (its heavy
#: imports — pytest, scipy, SALib, dask, SQLAlchemy — never slow another command, ``--help`` or
#: ``--version`` down); ``tests/cli/test_quick_start.py`` checks each help line against the one
#: the module registers. A new command is one line here plus its module's ``register``.
COMMANDS: dict[str, tuple[str, str]] = {
    "run": ("run", "run the test plans, record the run, write the report"),
    "sim-bench": ("sim_bench", "start the simulated instruments; print a bench file for them"),
    "analyze": ("analyze", "torque-ripple metrics of a capture file"),
    "report": ("report", "PDF test report of a run record"),
    "verify": ("verify", "check a run record's hashes and signature (record.json and every "
                         "capture)"),
    "predict": ("predict", "closed-form ripple prediction of one source"),
    "budget": ("budget", "invert a ripple limit into controller limits"),
    "yield": ("yield_cmd", "Monte Carlo yield of a ripple limit over tolerances"),
    "diagnose": ("diagnose", "attribute the measured ripple to its sources (offsets, gains, dead "
                             "time, encoder, motor) and suggest the calibration"),
    "export": ("export", "export a record's captures as ASAM MDF4 files (with units and "
                         "provenance)"),
    "db": ("db", "results database: sync, import, export, verify"),
    "history": ("history", "runs in the results database"),
    "compare": ("compare", "two runs side by side, differences with U"),
    "trend": ("trend", "control chart, Cp/Cpk and measured yield over runs"),
    "station": ("station", "the operator's page in the browser"),
    "characterize": ("characterize", "measure the motor and current loop on the bench (stated vs "
                                     "measured, with U); write its twin"),
    "campaign": ("campaign", "a regression grid of plan runs on Dask (bench variations x plan "
                             "selections)"),
}


class UsageError(Exception):
    """A command line argparse refused; ``prog`` is the (sub)command that refused it."""

    def __init__(self, prog: str, message: str) -> None:
        super().__init__(message)
        self.prog = prog


def one_line_error_parser() -> type:
    """argparse's parser class whose usage errors become :class:`UsageError` (one line, exit 2,
    no usage dump); made on first use so that importing this module does not import argparse."""
    import argparse

    class OneLineErrorParser(argparse.ArgumentParser):
        def error(self, message: str) -> None:  # noqa: D102 - argparse API
            raise UsageError(self.prog, message)

    return OneLineErrorParser


def build_parser(argv: list[str] | None = None):
    """The parser (an ``argparse.ArgumentParser``); with ``argv`` naming a command, that
    command's module is imported and registers its full parser; every other command gets a
    placeholder parser carrying only its help line (so ``hil --help`` and ``hil --version``
    import no command module)."""
    import importlib

    from hil import __version__

    parser_class = one_line_error_parser()
    parser = parser_class(prog="hil", description=DESCRIPTION, epilog=EPILOG)
    parser.add_argument("--version", action="version", version=f"ripple-hil {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND",
                                       parser_class=parser_class)
    subparsers.required = True
    named = _command_named(argv)
    for name, (module, help_line) in COMMANDS.items():
        if name == named:
            importlib.import_module(f"hil.commands.{module}").register(subparsers)
        else:
            subparsers.add_parser(name, help=help_line)
    return parser


def _command_named(argv: list[str] | None) -> str | None:
    """The command name ``argv``'s first word gives, if it is one (None otherwise)."""
    first = next((word for word in argv or () if not word.startswith("-")), None)
    return first if first in COMMANDS else None


def report_error(command: str, kind: str, message: str, status: int, as_json: bool) -> int:
    """Print an error (one stderr line; with ``as_json`` also a JSON object on stdout)."""
    label = {"usage": "error", "input": "error", "failed": "failed",
             "interrupted": "interrupted"}[kind]
    text = f"{command}: {label}" + (f": {message}" if message else "")
    print(text, file=sys.stderr)
    if as_json:
        import json

        print(json.dumps({"error": {"command": command, "kind": kind, "message": message,
                                    "exit_status": status}}))
    return status


def main(argv: list[str] | None = None) -> int:
    """Run one ``hil`` command; its exit status (Ctrl-C anywhere in here: one line, 130)."""
    argv = sys.argv[1:] if argv is None else list(argv)
    as_json = "--json" in argv
    command = f"hil {_command_named(argv) or ''}".strip()   # before parsing: the word typed
    try:
        from hil.errors import HilError, InputError

        parser = build_parser(argv)
        try:
            args = parser.parse_args(argv)
        except UsageError as exc:
            return report_error(exc.prog, "usage", str(exc), 2, as_json)
        command = f"hil {args.command}"
        try:
            return int(args.func(args) or 0)
        except InputError as exc:
            return report_error(command, "input", str(exc), 2, as_json)
        except HilError as exc:
            return report_error(command, "failed", str(exc), 1, as_json)
    except KeyboardInterrupt:
        return report_error(command, "interrupted", "", 130, as_json)
    except BrokenPipeError:  # output piped into e.g. head, which stopped reading
        import os

        sys.stdout = open(os.devnull, "w")
        return 0


if __name__ == "__main__":
    sys.exit(main())
