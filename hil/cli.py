"""The ``hil`` command line: one sub-command per module in ``hil.commands``.

Each command module defines ``register(subparsers)``, which adds its parser and sets
``func(args) -> int``. Errors: bad input (including a usage error) prints one line on stderr and
exits 2; an instrument or run failure prints one line and exits 1; Ctrl-C exits 130. ``--json``
output is one JSON object on stdout; with ``--json`` an error is also one JSON object on stdout,
``{"error": {"command", "kind" (usage | input | failed | interrupted), "message",
"exit_status"}}``, beside the one-line message on stderr.
"""

from __future__ import annotations

import argparse
import importlib
import json
import os
import sys

from hil import __version__
from hil.errors import HilError, InputError

DESCRIPTION = ("ripple-hil: hardware-in-the-loop bench tests of the torque ripple a PMSM drive's "
               "controller adds, judged against the closed-form predictions of Chen, Namuduri "
               "and Mir (IEEE Trans. Ind. Appl. 38(5), 2002).")
EPILOG = ("Run 'hil COMMAND --help' for a command's options. Bad input exits 2 with one line on "
          "stderr, a failed run exits 1; with --json an error is also a JSON object on stdout.")

#: Command modules under ``hil.commands``, in the order ``hil --help`` lists them.
COMMAND_MODULES: list[str] = ["run", "sim_bench", "analyze", "report", "verify", "predict", "budget",
                              "yield_cmd", "diagnose"]
#: Command names whose module name differs (the others are their module's name).
COMMAND_NAMES = {"sim_bench": "sim-bench", "yield_cmd": "yield"}


class UsageError(Exception):
    """A command line argparse refused; ``prog`` is the (sub)command that refused it."""

    def __init__(self, prog: str, message: str) -> None:
        super().__init__(message)
        self.prog = prog


class OneLineErrorParser(argparse.ArgumentParser):
    """argparse whose usage errors become :class:`UsageError` (one line, exit 2, no usage dump)."""

    def error(self, message: str) -> None:  # noqa: D102 - argparse API
        raise UsageError(self.prog, message)


def build_parser(argv: list[str] | None = None) -> argparse.ArgumentParser:
    """The parser; with ``argv`` naming a command, only that command's module is imported (a
    command's heavy imports — SALib, scipy.stats, dask — never slow another command down)."""
    parser = OneLineErrorParser(prog="hil", description=DESCRIPTION, epilog=EPILOG)
    parser.add_argument("--version", action="version", version=f"ripple-hil {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND",
                                       parser_class=OneLineErrorParser)
    subparsers.required = True
    for name in _modules_for(argv):
        importlib.import_module(f"hil.commands.{name}").register(subparsers)
    return parser


def _modules_for(argv: list[str] | None) -> list[str]:
    """The command module ``argv``'s first word names, else every module (help, errors)."""
    first = next((word for word in argv or () if not word.startswith("-")), None)
    for name in COMMAND_MODULES:
        if first == COMMAND_NAMES.get(name, name):
            return [name]
    return COMMAND_MODULES


def report_error(command: str, kind: str, message: str, status: int, as_json: bool) -> int:
    """Print an error (one stderr line; with ``as_json`` also a JSON object on stdout)."""
    label = {"usage": "error", "input": "error", "failed": "failed",
             "interrupted": "interrupted"}[kind]
    text = f"{command}: {label}" + (f": {message}" if message else "")
    print(text, file=sys.stderr)
    if as_json:
        print(json.dumps({"error": {"command": command, "kind": kind, "message": message,
                                    "exit_status": status}}))
    return status


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    as_json = "--json" in argv
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
        sys.stdout = open(os.devnull, "w")
        return 0


if __name__ == "__main__":
    sys.exit(main())
