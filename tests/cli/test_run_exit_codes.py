"""``hil run``'s documented exit codes for input it refuses after pytest has started: a pytest
usage error and a selection that collects no point are both "bad input", exit 2 (not pytest's
4 and 5), with one line saying why; nothing is recorded."""

from __future__ import annotations

import subprocess
import sys

from hil.commands import run as run_command

HIL_RUN = [sys.executable, "-m", "hil", "run", "--source", "baseline", "--no-report"]


def test_the_exit_codes_are_documented_in_the_help_epilog():
    epilog = run_command.__doc__.split("\n\n")[-1]
    assert epilog.startswith("Exit codes:") and "2 interrupted (Ctrl-C) or bad" in epilog
    assert "5 nothing collected" not in epilog


def test_a_selection_that_collects_nothing_exits_2(tmp_path):
    done = subprocess.run(HIL_RUN + ["--record-dir", str(tmp_path / "records"), "--",
                                     "-k", "no_test_has_this_name"],
                          capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert done.returncode == 2, done.stdout[-2000:] + done.stderr[-2000:]
    assert "hil run: no test plan point was collected" in done.stderr
    assert "Traceback" not in done.stdout + done.stderr
    assert not (tmp_path / "records").exists()
