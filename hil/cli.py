"""The ``hil`` command line: one sub-command per module in ``hil.commands``.

Each command module defines ``register(subparsers)``, which adds its parser and sets
``func(args) -> int``. Errors: bad input prints one line on stderr and exits 2; an instrument or
run failure prints one line and exits 1; ``--json`` output is one JSON object on stdout.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from hil import __version__
from hil.errors import HilError, InputError

#: Command modules under ``hil.commands``, in the order ``hil --help`` lists them.
COMMAND_MODULES: list[str] = ["run", "sim_bench", "analyze", "report", "predict", "budget",
                              "yield_cmd"]


class OneLineErrorParser(argparse.ArgumentParser):
    """argparse that reports a usage error on one stderr line and exits 2 (no usage dump)."""

    def error(self, message: str) -> None:  # noqa: D102 - argparse API
        self.exit(2, f"{self.prog}: error: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    parser = OneLineErrorParser(prog="hil", description=__doc__.splitlines()[0])
    parser.add_argument("--version", action="version", version=f"ripple-hil {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND",
                                       parser_class=OneLineErrorParser)
    subparsers.required = True
    for name in COMMAND_MODULES:
        importlib.import_module(f"hil.commands.{name}").register(subparsers)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except InputError as exc:
        print(f"hil {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except HilError as exc:
        print(f"hil {args.command}: failed: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"hil {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
