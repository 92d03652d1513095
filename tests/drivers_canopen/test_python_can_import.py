"""``ripple_hil_drivers.python_can``: python-can imported without asammdf (and pandas), asammdf
still importable afterwards and writing MDF4 as before; in a fresh interpreter each."""

import subprocess
import sys

import pytest


def run(code: str) -> str:
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0, done.stderr
    return done.stdout.strip()


def test_can_through_hil_does_not_import_asammdf_or_pandas():
    out = run("import hil.config, canopen, sys; "
              "print(sorted(m for m in ('asammdf', 'pandas') if m in sys.modules))")
    assert out == "[]"


def test_asammdf_after_can_writes_and_reads_mdf4(tmp_path):
    code = f"""
import numpy as np, hil, can
from asammdf import MDF, Signal
mdf = MDF(version="4.10")
mdf.append([Signal(np.arange(5.0), np.arange(5) * 1e-3, name="ia_a", unit="A")])
mdf.save(r"{tmp_path / 'x.mf4'}", overwrite=True)
print(MDF(r"{tmp_path / 'x.mf4'}").get("ia_a").samples.tolist())
"""
    assert run(code) == "[0.0, 1.0, 2.0, 3.0, 4.0]"


@pytest.mark.parametrize("first", ["asammdf", "can"])
def test_either_import_order_leaves_both_usable(first):
    second = "can" if first == "asammdf" else "asammdf"
    out = run(f"import ripple_hil_drivers, {first}, {second}; "
              "print(can.Message(arbitration_id=1).arbitration_id, asammdf.MDF.__name__)")
    assert out == "1 MDF"
