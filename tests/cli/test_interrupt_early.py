"""Ctrl-C while ``hil run`` is still importing, building its parser or loading pytest: one line,
no traceback, exit 130 (or ``hil run``'s documented 2 once pytest's session has begun).

The real console script runs in a subprocess under ``python -X importtime``, whose per-module
lines on stderr tell the test which phase the process is in; SIGINT is sent as soon as a phase's
module has been imported (so it lands in that phase or shortly after, never in the interpreter's
own start-up, which no program can guard).
"""

import os
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest

HIL_SCRIPT = shutil.which("hil", path=str(Path(sys.executable).parent))

#: imported module → the phase it marks; and the exit statuses allowed after SIGINT there.
PHASES = {
    "argparse": ("building the parser", {130}),
    "signal": ("starting run() (its first import)", {130}),
    "pytest": ("run() having imported pytest", {130}),
    # (the plan modules now import hil.measurement lazily, inside pytest's fd capture, where
    # -X importtime's lines do not reach this test: the plugin's own pre-flight module marks
    # the same phase)
    "ripple_hil_fixtures.preflight": ("pytest loading the ripple-hil plugin and the plans",
                                      {2, 130}),
}


def interrupted_after(module: str, tmp_path: Path) -> tuple[int, str]:
    """Start ``hil run``, SIGINT it once ``module`` is imported; its exit status and stderr."""
    argv = [sys.executable, "-X", "importtime", HIL_SCRIPT, "run", "--source", "dc_offset",
            "--no-report", "--record-dir", str(tmp_path / "records")]
    process = subprocess.Popen(argv, cwd=tmp_path, stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True,
                               env={**os.environ, "PYTHONUNBUFFERED": "1"},
                               preexec_fn=default_sigint)
    seen = []
    try:
        for line in process.stderr:
            seen.append(line)
            # a progress bar (no newline) may stand before the importtime line on stderr
            if "import time:" in line and line.split("|")[-1].strip() == module:
                break
        else:
            pytest.fail(f"{module} was never imported:\n{''.join(seen[-5:])}")
        process.send_signal(signal.SIGINT)
        _, rest = process.communicate(timeout=60)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
    return process.returncode, "".join(seen) + rest


def default_sigint() -> None:
    """In the child: SIGINT's default action, even if this test runs with SIGINT ignored (a
    background job of a non-interactive shell); Python then installs its Ctrl-C handler."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def own_lines(stderr: str) -> list[str]:
    """stderr without ``-X importtime``'s per-module lines."""
    return [line for line in stderr.splitlines() if not line.startswith("import time:")]


@pytest.mark.skipif(HIL_SCRIPT is None, reason="the hil console script is not installed")
@pytest.mark.parametrize("module", list(PHASES))
def test_ctrl_c_while_loading_prints_one_line_and_no_traceback(module, tmp_path):
    phase, allowed = PHASES[module]
    code, stderr = interrupted_after(module, tmp_path)
    lines = own_lines(stderr)
    assert "Traceback" not in stderr, f"Ctrl-C while {phase}:\n" + "\n".join(lines)
    assert code in allowed, f"Ctrl-C while {phase}: exit {code}\n" + "\n".join(lines)
    if code == 130:
        assert lines == ["hil run: interrupted"]
