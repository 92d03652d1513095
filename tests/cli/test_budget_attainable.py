"""``hil budget`` says when a limit cannot be met and exits 1; a limit too small to invert is
one error line (no traceback), with a JSON error object under --json."""

import json
import subprocess
import sys

HIL = [sys.executable, "-m", "hil"]


def budget(*args):
    return subprocess.run(HIL + ["budget", *args], capture_output=True, text=True, timeout=120)


def test_an_unattainable_limit_is_stated_and_exits_1():
    done = budget("--limit-pct", "2")
    assert done.returncode == 1, done.stderr
    assert done.stdout.splitlines()[-1].startswith("LIMIT NOT ATTAINABLE: 2 % of the air-gap torque is not met")
    data = json.loads(budget("--limit-pct", "2", "--json").stdout)
    assert data["attainable"] is False and data["not_met"]


def test_a_limit_too_small_to_invert_is_one_error_line():
    done = budget("--limit-pct", "1e-9")
    assert done.returncode == 2 and done.stderr.count("\n") == 1
    assert "Traceback" not in done.stderr
    error = json.loads(budget("--limit-pct", "1e-9", "--json").stdout)["error"]
    assert error["kind"] == "input" and error["exit_status"] == 2


def test_a_prediction_per_unit_of_a_zero_mean_torque_is_refused():
    done = subprocess.run(HIL + ["predict", "dc_offset", "--ia-offset-a", "0.2",
                                 "--current-angle-deg", "90"], capture_output=True, text=True,
                          timeout=60)
    assert done.returncode == 2 and "undefined" in done.stderr and "e+16" not in done.stdout
