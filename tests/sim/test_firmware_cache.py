"""The firmware's exact modulo (no library fmod) equals Python's ``%`` on its inputs.

Checked through ``py_func`` (the same source run by the interpreter) so that this test compiles
nothing: the engine's firmware is compiled inside the kernel (see ``hil.sim.kernel``).
"""

from __future__ import annotations

import numpy as np

from hil.sim.firmware import _modulo


def test_modulo_equals_python_modulo_for_integer_floats():
    rng = np.random.default_rng(1)
    values = np.concatenate([rng.integers(-10**12, 10**12, 2000), np.arange(-40, 40),
                             [0, 7199, 7200, 7201, -7200, -7201, 2**52, -2**52]]).astype(float)
    for modulus in (6.0, 4096.0, 7200.0):
        for value in values:
            assert _modulo.py_func(float(value), modulus) == float(value) % modulus
