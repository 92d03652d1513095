"""Done-when of issue 24: two runs of the simulated drive, the second with a hidden phase-a
current-sensor offset of 0.3 A: ``hil compare`` names the points that changed beyond U_d and no
others; a correct drive run again (another noise seed) changes no point beyond U_d."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from hil.cli import main

SOURCES = ["--source", "baseline", "--source", "pwm_switching"]


def _start(records, *extra: str) -> subprocess.Popen:
    env = os.environ | {"PYTHONPATH": os.pathsep.join(sys.path)}
    return subprocess.Popen([sys.executable, "-m", "hil", "run", *SOURCES, "--record-dir",
                             str(records), "--no-report", *extra], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env)


pytestmark = pytest.mark.slow      # three `hil run`s of 6 points each, side by side


@pytest.fixture(scope="module")
def three_runs(tmp_path_factory):
    """The three runs at once (each its own simulated bench, ports and CAN channel)."""
    root = tmp_path_factory.mktemp("records")
    runs = {"clean": ("--seed", "0"), "reseeded": ("--seed", "1"),
            "defective": ("--seed", "0", "--sim-defect", "hidden_ia_offset_a=0.3")}
    procs = {name: _start(root / name, *extra) for name, extra in runs.items()}
    for proc in procs.values():
        _, err = proc.communicate(timeout=300)
        assert proc.returncode in (0, 1), err[-2000:]
    ids = {name: next(p.name for p in (root / name).iterdir() if p.is_dir()) for name in runs}
    return root, (ids["clean"], ids["reseeded"], ids["defective"])


def _compare(capsys, records, a, b, *extra):
    capsys.readouterr()
    assert main(["compare", a, b, "--records", str(records), "--json", *extra]) == 0
    return json.loads(capsys.readouterr().out)


def test_compare_names_the_points_the_defect_changed_and_no_others(three_runs, capsys,
                                                                   tmp_path):
    records, (clean, reseeded, defective) = three_runs
    assert main(["db", "sync", "--records", str(records)]) == 0
    result = _compare(capsys, records, clean, defective, "-o", str(tmp_path / "cmp.png"))
    # a 0.3 A offset (1.5 % of 20 A) adds an order-1 ripple of ~3 % pk-pk (eqs 15-20): every
    # point at 20 A whose pk-pk is set by the synchronous average changes; the PWM-switching
    # points judge the switching-frequency ripple, which a dc offset does not move
    assert sorted(result["changed"]) == ["testplans/test_baseline.py::test_baseline",
                                         "testplans/test_self_check.py::test_bench_self_check"]
    assert sorted(result["unchanged"]) == sorted(
        f"testplans/test_pwm_switching.py::test_pwm_switching[pwm_frequency_hz={f}]"
        for f in (10000, 20000, 40000))
    baseline = next(p for p in result["points"] if p["test_id"].endswith("test_baseline"))
    assert baseline["pk_pk_pu"]["difference"] > 10 * baseline["pk_pk_pu"]["u_difference"]
    assert (tmp_path / "cmp.png").stat().st_size > 1000
    # the correct drive again, other transducer noise: nothing beyond U_d
    again = _compare(capsys, records, clean, reseeded)
    assert again["changed"] == [] and len(again["unchanged"]) == 5
