"""Done-when of issue 24: two runs of the simulated drive, the second with a hidden phase-a
current-sensor offset of 0.3 A (and other transducer noise): ``hil compare`` names the points that
changed beyond U_d and no others; a correct drive run twice off the default point (reverse
rotation, −700 rpm, 12 A; other noise seed) changes no point beyond U_d."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from hil.cli import main
from hil.config import example_bench_path

SOURCES = ["--source", "baseline", "--source", "pwm_switching"]


def _start(records, *extra: str) -> subprocess.Popen:
    env = os.environ | {"PYTHONPATH": os.pathsep.join(sys.path)}
    return subprocess.Popen([sys.executable, "-m", "hil", "run", *SOURCES, "--record-dir",
                             str(records), "--no-report", *extra], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env)


pytestmark = pytest.mark.slow      # four `hil run`s of 6 points each, side by side


@pytest.fixture(scope="module")
def four_runs(tmp_path_factory):
    """The four runs at once (each its own simulated bench, ports and CAN channel)."""
    root = tmp_path_factory.mktemp("records")
    bench = root / "reverse.toml"
    text = example_bench_path("sim-bench").read_text()
    assert "speed_rpm = 500.0" in text and "current_a = 20.0" in text
    bench.write_text(text.replace("speed_rpm = 500.0", "speed_rpm = -700.0", 1)
                     .replace("current_a = 20.0", "current_a = 12.0", 1))
    runs = {"clean": ("--seed", "0"),
            "defective": ("--seed", "1", "--sim-defect", "hidden_ia_offset_a=0.3"),
            "reverse": ("--bench", str(bench), "--seed", "0"),
            "reverse_again": ("--bench", str(bench), "--seed", "1")}
    procs = {name: _start(root / name, *extra) for name, extra in runs.items()}
    for name, proc in procs.items():
        out, err = proc.communicate(timeout=300)
        # the correct drive passes at both points (a wrongly rejected one was let through by
        # 'in (0, 1)'); the defective one fails its baseline
        assert proc.returncode == (1 if name == "defective" else 0), (name, out[-2000:],
                                                                       err[-2000:])
    return root, {name: next(p.name for p in (root / name).iterdir() if p.is_dir())
                  for name in runs}


def _compare(capsys, records, a, b, *extra):
    capsys.readouterr()
    assert main(["compare", a, b, "--records", str(records), "--json", *extra]) == 0
    return json.loads(capsys.readouterr().out)


def test_compare_names_the_points_the_defect_changed_and_no_others(four_runs, capsys,
                                                                   tmp_path):
    records, ids = four_runs
    assert main(["db", "sync", "--records", str(records)]) == 0
    result = _compare(capsys, records, ids["clean"], ids["defective"],
                      "-o", str(tmp_path / "cmp.png"))
    # a 0.3 A offset (1.5 % of 20 A) adds an order-1 ripple of ~3.5 % pk-pk (eqs 15-20): the
    # points whose pk-pk is the synchronous average's change; the PWM-switching points judge
    # the switching-frequency ripple, which a dc offset does not move
    # (the self-check's transducer-dynamics pair, at the point's speed and one fifth of it,
    # measures the torque ripple too: the offset's order-1 ripple moves both)
    assert sorted(result["changed"]) == [
        "testplans/test_baseline.py::test_baseline",
        "testplans/test_self_check.py::test_bench_self_check",
        "testplans/test_self_check.py::test_transducer_dynamics",
        "testplans/test_self_check.py::test_transducer_dynamics-reference"]
    # ... nor the self-check's angle reference (back EMF, drive disabled: no current at all)
    assert sorted(result["unchanged"]) == sorted(
        [f"testplans/test_pwm_switching.py::test_pwm_switching[pwm_frequency_hz={f}]"
         for f in (10000, 20000, 40000)] + ["testplans/test_self_check.py::test_angle_reference"])
    baseline = next(p for p in result["points"] if p["test_id"].endswith("test_baseline"))
    assert baseline["pk_pk_pu"]["difference"] > 10 * baseline["pk_pk_pu"]["u_difference"]
    assert (tmp_path / "cmp.png").stat().st_size > 1000


def test_a_correct_drive_off_the_default_point_changes_nothing(four_runs, capsys):
    records, ids = four_runs
    assert main(["db", "sync", "--records", str(records)]) == 0
    again = _compare(capsys, records, ids["reverse"], ids["reverse_again"])
    # the bench's point, and the self-check's transducer-dynamics reference at one fifth of it
    assert {p["speed_rpm"] for p in again["points"] if p["speed_rpm"] is not None} == {
        -700.0, -140.0}
    assert again["changed"] == [] and len(again["unchanged"]) == 8
