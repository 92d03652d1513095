"""Ctrl-C when pytest's own Ctrl-C report fails: the record still says "interrupted" and
``hil run`` prints one line, exit 2.

Why it happens: CPython 3.11 gives ``tb_lineno`` None for a KeyboardInterrupt raised at an
instruction without a line number (measured: ~1 in 1,000 signals in a loop of with/for blocks),
and pytest 9's traceback formatting computes ``tb_lineno - 1``: its terminal reporter's
``pytest_keyboard_interrupt`` raises TypeError inside ``wrap_session``'s Ctrl-C handler. Seen once
as a traceback after a SIGINT to ``hil run``. The first test reproduces the ordering with a
conftest hook that raises as the reporter does; the second checks ``hil run``'s handling.
"""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import textwrap
from types import SimpleNamespace

import pytest

from hil.commands import run as run_command

CONFTEST = textwrap.dedent('''
    def pytest_keyboard_interrupt(excinfo):
        # as pytest's terminal reporter fails on a tb_lineno of None
        None - 1
''')
PLAN = textwrap.dedent('''
    def test_first(bench):
        assert bench.config.simulated

    def test_ctrl_c(bench):
        raise KeyboardInterrupt

    def test_never_reached(bench):
        assert bench.config.simulated
''')


def test_the_record_says_interrupted_when_the_ctrl_c_report_fails(tmp_path):
    (tmp_path / "conftest.py").write_text(CONFTEST)
    (tmp_path / "test_plan.py").write_text(PLAN)
    done = subprocess.run([sys.executable, "-m", "pytest", "test_plan.py", "-q", "-p",
                           "no:cacheprovider", "--hil-record", "records"],
                          capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert "unsupported operand" in done.stderr, done.stderr[-2000:]   # the hook did raise
    (folder,) = (tmp_path / "records").iterdir()
    record = json.loads((folder / "record.json").read_text())
    assert record["status"] == "interrupted", record["status"]
    outcomes = {test["test_id"].split("::")[-1]: test for test in record["tests"]}
    assert outcomes["test_first"]["outcome"] == "passed"
    assert outcomes["test_never_reached"]["outcome"] == "not run"
    assert "Ctrl-C" in outcomes["test_never_reached"]["message"]


def test_hil_run_prints_one_line_and_exits_2(monkeypatch, capsys):
    def failing_report(args):
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt:
            None - 1            # noqa: B018 - what pytest's reporter does with tb_lineno None

    monkeypatch.setattr(run_command, "build_pytest_args", lambda args: [])
    monkeypatch.setattr(signal, "signal", lambda *a: None)     # run()'s SIGTERM handler
    monkeypatch.setattr(pytest, "main", failing_report)
    assert run_command.run(SimpleNamespace()) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("hil run: interrupted (pytest's Ctrl-C report "
                                                   "failed: TypeError: unsupported operand")


def test_any_other_error_out_of_pytest_is_not_called_an_interrupt(monkeypatch):
    def broken(args):
        raise TypeError("a bug, not Ctrl-C")

    monkeypatch.setattr(run_command, "build_pytest_args", lambda args: [])
    monkeypatch.setattr(signal, "signal", lambda *a: None)
    monkeypatch.setattr(pytest, "main", broken)
    with pytest.raises(TypeError, match="a bug"):
        run_command.run(SimpleNamespace())
