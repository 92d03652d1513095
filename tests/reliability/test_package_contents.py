"""What an installation of the project contains (setuptools' build step, run on a copy of the
source tree): every package, the drivers' data files and the examples, with no data folder that
setuptools only picks up by a deprecated fallback ("Package would be ignored")."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
FOLDERS = ("hil", "drivers", "fixtures", "testplans", "reports")
DATA_FILES = ("ripple_hil_drivers/data/ripple_drive.eds",
              "ripple_hil_drivers/data/ripple_drive_profile.toml",
              "ripple_hil_drivers/data/daq_registers.toml",
              "hil/examples/sim-bench.toml", "hil/examples/real-bench.toml",
              "hil/examples/requirements.toml", "hil/examples/tolerances.toml")


def test_built_package_holds_the_data_files_without_deprecated_fallbacks(tmp_path):
    source = tmp_path / "source"
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc", "*.nbi", "*.nbc")
    for folder in FOLDERS:
        shutil.copytree(REPO / folder, source / folder, ignore=ignore)
    for name in ("pyproject.toml", "README.md"):
        shutil.copy2(REPO / name, source / name)
    done = subprocess.run([sys.executable, "-c", "from setuptools import setup; setup()",
                           "build_py", "--build-lib", str(tmp_path / "lib")],
                          cwd=source, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "Package would be ignored" not in done.stdout + done.stderr, done.stderr[-3000:]
    lib = tmp_path / "lib"
    assert sorted(p.name for p in lib.iterdir()) == [
        "hil", "ripple_hil_drivers", "ripple_hil_fixtures", "ripple_hil_reports",
        "ripple_hil_testplans"]
    for name in DATA_FILES:
        assert (lib / name).is_file(), name
    assert (lib / "ripple_hil_drivers" / "simulated" / "modbus_daq_server.py").is_file()
    installed_as = {"hil": "hil", "drivers": "ripple_hil_drivers", "fixtures": "ripple_hil_fixtures",
                    "testplans": "ripple_hil_testplans", "reports": "ripple_hil_reports"}
    missing = [str(path.relative_to(source)) for folder in FOLDERS
               for path in (source / folder).rglob("*.py")
               if not (lib / installed_as[folder] / path.relative_to(source / folder)).is_file()]
    assert not missing, f"modules a non-editable install leaves out: {missing}"
