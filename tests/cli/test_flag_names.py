"""Messages printed during a run name the flag the user typed: ``hil run --operator`` users read
``--operator``, pytest users read ``--hil-operator`` (the plugin's spelling). Both real command
lines in subprocesses; the bench is refused before it opens, so each takes about a second."""

from __future__ import annotations

import datetime as dt
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest
import tomli_w

import ripple_hil_testplans
from hil.commands.run import PLUGIN_OPTIONS, RUN_FLAGS
from hil.config import example_bench_path

HIL_RUN = [sys.executable, "-m", "hil", "run", "--source", "dc_offset", "--no-report"]
PLAN = str(Path(ripple_hil_testplans.__file__).parent / "test_dc_offset.py")
PYTEST = [sys.executable, "-m", "pytest", PLAN, "-q", "-p", "no:cacheprovider"]


def expired_bench_file(tmp_path: Path) -> str:
    """The shipped simulated bench file with the transducer's calibration overdue."""
    table = tomllib.loads(example_bench_path("sim-bench").read_text())
    torque = next(entry for entry in table["instrument"] if entry["role"] == "torque")
    torque["calibration_date"], torque["calibration_due"] = dt.date(2025, 1, 10), \
        dt.date(2026, 1, 10)
    path = tmp_path / "expired.toml"
    path.write_text(tomli_w.dumps(table))
    return str(path)


def run(argv: list[str], tmp_path: Path) -> tuple[int, str]:
    done = subprocess.run(argv, capture_output=True, text=True, timeout=120, cwd=tmp_path)
    return done.returncode, done.stdout + done.stderr


def test_every_hil_run_option_has_its_own_flag_name():
    """So no message can name a plugin option the ``hil run`` user has no flag for."""
    assert set(PLUGIN_OPTIONS.values()) <= set(RUN_FLAGS)
    assert all(not flag.startswith("--hil-") for flag in RUN_FLAGS.values())


def test_expired_calibration_names_hil_runs_flags(tmp_path):
    code, text = run(HIL_RUN + ["--bench", expired_bench_file(tmp_path),
                                "--record-dir", str(tmp_path / "records")], tmp_path)
    assert code == 6, text
    assert "give --allow-expired-calibration REASON --operator NAME to override" in text
    assert "--hil-" not in text
    code, text = run(HIL_RUN + ["--bench", expired_bench_file(tmp_path),
                                "--allow-expired-calibration", "certificate in the post",
                                "--record-dir", str(tmp_path / "records")], tmp_path)
    assert code == 6 and "a calibration override needs --operator NAME" in text, text
    assert "--hil-" not in text
    assert not (tmp_path / "records").exists()


def test_expired_calibration_names_the_plugins_flags_under_pytest(tmp_path):
    code, text = run(PYTEST + ["--hil-bench", expired_bench_file(tmp_path),
                               "--hil-record", str(tmp_path / "records")], tmp_path)
    assert code == 6, text
    assert ("give --hil-allow-expired-calibration REASON --hil-operator NAME to override"
            in text)


@pytest.mark.parametrize("hil_args, pytest_args, words", [
    (["--item-received", "2026-13-01"], ["--hil-item-received", "2026-13-01"],
     "{} '2026-13-01' must be a date like 2026-03-31"),
    (["--sim-defect", "injection_scale"], ["--hil-sim-defect", "injection_scale"],
     "{}: defect 'injection_scale' must be written KEY=VALUE"),
    (["--sim-defect", "no_such_defect=1"], ["--hil-sim-defect", "no_such_defect=1"],
     "{}: {}: unknown simulated-drive defect(s) ['no_such_defect']"),
])
def test_a_bad_option_value_is_named_as_typed(tmp_path, hil_args, pytest_args, words):
    """A bad value is one usage error naming the flag as typed; ``hil run`` exits 2 (bad input,
    as documented), pytest 4 (its usage error); no record either way."""
    shipped = str(example_bench_path("sim-bench"))
    code, text = run(HIL_RUN + hil_args + ["--record-dir", str(tmp_path / "records")], tmp_path)
    assert code == 2 and words.format(hil_args[0], shipped) in text, text
    assert "--hil-" not in text
    code, text = run(PYTEST + pytest_args + ["--hil-record", str(tmp_path / "records")], tmp_path)
    assert code == 4 and words.format(pytest_args[0], shipped) in text, text
    assert not (tmp_path / "records").exists()


def test_a_defect_on_a_real_bench_names_sim_defect(tmp_path):
    real = str(example_bench_path("real-bench"))
    code, text = run(HIL_RUN + ["--bench", real, "--sim-defect", "injection_scale=1.2",
                                "--record-dir", str(tmp_path / "records")], tmp_path)
    assert code == 2, text
    assert "--sim-defect: test-only defects need a simulated bench (simulated = true)" in text
    assert "--hil-" not in text
    code, text = run(PYTEST + ["--hil-bench", real, "--hil-sim-defect", "injection_scale=1.2",
                               "--hil-record", str(tmp_path / "records")], tmp_path)
    assert code == 4, text
    assert "--hil-sim-defect: test-only defects need a simulated bench" in text


def test_a_bad_requirements_file_is_named_where_the_user_named_it(tmp_path):
    bad = tmp_path / "bad-req.toml"
    bad.write_text('[[requirement]]\nid = "REQ-1"\nquantity = "pk_pk_pct"\n')   # no limit
    code, text = run(HIL_RUN + ["--requirements", str(bad)], tmp_path)
    assert code == 2 and f"{bad}: requirement 'REQ-1'" in text and "--hil-" not in text, text
    code, text = run(PYTEST + ["--hil-requirements", str(bad)], tmp_path)
    assert code != 0 and "--hil-requirements: " in text, text
    table = tomllib.loads(example_bench_path("sim-bench").read_text())
    table["requirements"] = {"file": str(bad)}
    bench = tmp_path / "with-req.toml"
    bench.write_text(tomli_w.dumps(table))
    code, text = run(HIL_RUN + ["--bench", str(bench)], tmp_path)
    assert code == 2 and "the bench file's [requirements] file: " in text, text
    assert "--hil-requirements" not in text and "--requirements:" not in text, text
