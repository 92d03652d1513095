"""Quick start (issue 33 item 2): ``hil --version``/``--help`` import no command module, and each
command's ``--help`` imports only what that command needs. Import-set tests, not timings: a
fresh interpreter runs the command and reports which of the heavy packages it imported."""

import json
import subprocess
import sys

import pytest

from hil.cli import COMMANDS, build_parser

#: Packages that cost 0.1–2 s each to import; the quick paths must not touch them.
HEAVY = ("numpy", "scipy", "numba", "llvmlite", "matplotlib", "dask", "distributed",
         "sqlalchemy", "alembic", "canopen", "can", "pymodbus", "serial", "pytest", "pandas",
         "SALib", "fpdf", "uvicorn", "starlette")

PROBE = """
import json, sys
from hil.cli import main
try:
    main(sys.argv[1:])
except SystemExit:
    pass
sys.stdout.flush()
print(json.dumps(sorted(m for m in sys.modules)), file=sys.stderr)
"""


def imported(*argv: str) -> tuple[set[str], set[str]]:
    """(heavy top-level packages, hil.commands modules) a fresh ``hil ARGV`` imported."""
    done = subprocess.run([sys.executable, "-c", PROBE, *argv], capture_output=True, text=True,
                          timeout=120)
    modules = set(json.loads(done.stderr.strip().splitlines()[-1]))
    return ({m for m in HEAVY if m in modules},
            {m for m in modules if m.startswith("hil.commands.")})


@pytest.mark.parametrize("argv", [["--version"], ["--help"], []])
def test_version_and_help_import_nothing_heavy(argv):
    heavy, commands = imported(*argv)
    assert heavy == set()
    assert commands == set(), "the top-level parser imported command modules"


@pytest.mark.parametrize("command", ["run", "report", "db", "station", "yield", "campaign"])
def test_light_commands_help_imports_nothing_heavy(command):
    """Commands whose parser needs no numeric or database package: their ``--help`` imports
    their own module and light helpers (predict, budget, analyze and diagnose need numpy for
    their choices; they are not in this list)."""
    heavy, commands = imported(command, "--help")
    assert heavy == set()
    assert f"hil.commands.{COMMANDS[command][0]}" in commands


def test_help_lines_are_the_ones_the_modules_register():
    """The registry's help line (what ``hil --help`` shows without importing) is the one each
    module gives ``add_parser`` (shown when the command is named)."""
    for name, (_, help_line) in COMMANDS.items():
        parser = build_parser([name])
        action = next(a for a in parser._subparsers._group_actions)  # the COMMAND action
        registered = {choice.dest: choice.help for choice in action._choices_actions}
        assert registered[name] == help_line, name
        assert action.choices[name].get_default("func") is not None, name


def test_yield_engines_match_the_engines_module():
    from hil.commands.yield_cmd import ENGINES
    from hil.tolerance.engines import ENGINES as engines

    assert ENGINES == engines


def test_named_command_still_parses_its_options():
    args = build_parser(["predict"]).parse_args(["predict", "dc_offset", "--json"])
    assert args.command == "predict" and args.json
