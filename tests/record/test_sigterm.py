"""SIGTERM is recorded as what it was (issue 22 item 8): a run terminated by SIGTERM (a CI
timeout, systemd, ``kill``) takes the Ctrl-C path (bench safe, record closed ``interrupted``)
but its record says ``interruption: {"signal": "SIGTERM"}`` and the tests not run say
"terminated (SIGTERM)", not "Ctrl-C"."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

from hil.outcome_kinds import MEASURED
from hil.record import load_record
from hil.seal import KEY_DIR_ENV

pytestmark = pytest.mark.timeout(240)

PLAN = '''
from hil.measurement import PointPlan


def test_quick(measure):
    measure(PointPlan(source="baseline", injection={}, speed_rpm=500.0, current_a=20.0,
                      revolutions=2, rule=None))


def test_long(measure):
    """Seconds of wall time (a long settle in simulated time): the signal comes during it."""
    measure(PointPlan(source="baseline", injection={}, speed_rpm=500.0, current_a=20.0,
                      revolutions=2, settle_s=55.0, rule=None))


def test_after(measure):
    measure(PointPlan(source="baseline", injection={}, speed_rpm=500.0, current_a=20.0,
                      revolutions=2, rule=None))
'''


def first_point_recorded(records) -> bool:
    for path in records.glob("*/record.json"):
        try:
            return any(t["outcome"] in ("passed", MEASURED)
                       for t in load_record(path.parent)["tests"])
        except Exception:  # noqa: BLE001 - a record being created
            return False
    return False


def test_sigterm_is_recorded_as_sigterm_not_ctrl_c(tmp_path):
    (tmp_path / "test_points.py").write_text(PLAN)
    records = tmp_path / "records"
    env = dict(os.environ, PYTHONUNBUFFERED="1", **{KEY_DIR_ENV: str(tmp_path / "keys")})
    run = subprocess.Popen([sys.executable, "-m", "pytest", "test_points.py", "-q",
                            "-p", "no:cacheprovider", "--hil-record", str(records)],
                           stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                           cwd=tmp_path, env=env)
    try:
        deadline = time.monotonic() + 150
        while not first_point_recorded(records):
            assert run.poll() is None, run.communicate()[0][-3000:]
            assert time.monotonic() < deadline, "no point recorded in time"
            time.sleep(0.05)
        time.sleep(0.5)                                   # inside the long point
        run.send_signal(signal.SIGTERM)
        output, _ = run.communicate(timeout=120)
    finally:
        if run.poll() is None:
            run.kill()
    record = load_record(next(records.glob("*/record.json")).parent)
    assert record["status"] == "interrupted", output[-3000:]
    assert record["interruption"]["signal"] == "SIGTERM"
    assert record["interruption"]["text"] == "terminated (SIGTERM)"
    after = next(t for t in record["tests"] if t["test_id"].endswith("test_after"))
    assert after["outcome"] == "not run" and "terminated (SIGTERM)" in after["message"]
    assert "Ctrl-C" not in after["message"]
    assert record["run"]["final_safe_state"] is not None
