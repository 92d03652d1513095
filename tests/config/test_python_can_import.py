"""``hil.python_can``: reading a bench file does not import asammdf and pandas through python-can
(issue 33: 0.35 s of every command's start), and asammdf still works where ripple-hil uses it."""

from __future__ import annotations

import json
import subprocess
import sys

PROBE = r"""
import json, sys
import hil.config
out = {"after_config": sorted(m for m in ("asammdf", "pandas") if m in sys.modules)}
import can.io.mf4
out["python_can_mf4"] = can.io.mf4.asammdf is not None
import asammdf
out["asammdf_after"] = bool(asammdf.__version__)
print(json.dumps(out))
"""

EARLY = r"""
import json, can
import hil.config, can.io.mf4
print(json.dumps({"python_can_mf4": can.io.mf4.asammdf is not None}))
"""


def _probe(script: str) -> dict:
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_a_bench_file_reader_imports_neither_asammdf_nor_pandas():
    out = _probe(PROBE)
    assert out["after_config"] == []                # was ["asammdf", "pandas"]
    assert out["python_can_mf4"] is False           # python-can's MF4 logger: off, as stated
    assert out["asammdf_after"] is True             # ripple-hil's MDF captures: still there


def test_a_process_that_imported_python_can_first_is_left_as_it_is():
    assert _probe(EARLY)["python_can_mf4"] is True
