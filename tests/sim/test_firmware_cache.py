"""The firmware's exact modulo (no library fmod) equals Python's ``%`` on its inputs.

Checked through ``py_func`` (the same source run by the interpreter) so that this test compiles
nothing: the engine's firmware is compiled inside the kernel (see ``hil.sim.kernel``).
"""

from __future__ import annotations

import numpy as np

from hil.sim.firmware import _modulo, _modulo_by


def test_modulo_equals_python_modulo_for_integer_floats():
    rng = np.random.default_rng(1)
    values = np.concatenate([rng.integers(-10**12, 10**12, 2000), np.arange(-40, 40),
                             [0, 7199, 7200, 7201, -7200, -7201, 2**52, -2**52]]).astype(float)
    for modulus in (6.0, 4096.0, 7200.0):
        for value in values:
            assert _modulo.py_func(float(value), modulus) == float(value) % modulus


def test_modulo_by_a_reciprocal_is_the_exact_modulo():
    """``_modulo_by`` (the quotient from a multiplication by 1/modulus, then corrected) gives
    the same bits as ``_modulo``, also where value/modulus is an integer or rounds across one,
    and so the decimated encoder count (counts − counts mod d) equals floor(counts/d)·d."""
    rng = np.random.default_rng(2)
    values = np.concatenate([rng.integers(-10**12, 10**12, 2000), np.arange(-40, 40),
                             [0, 7199, 7200, 7201, -7200, -7201, 2**52, -2**52]]).astype(float)
    for modulus in (3.0, 6.0, 7.0, 10.0, 4096.0, 7200.0, 8191.0):
        values_here = np.concatenate([values, modulus * rng.integers(-10**9, 10**9, 500),
                                      modulus * rng.integers(-10**9, 10**9, 500) - 1.0])
        for value in values_here:
            expected = float(value) % modulus
            assert _modulo_by.py_func(float(value), modulus, 1.0 / modulus) == expected
            if abs(value) < 2**40:
                assert value - expected == np.floor(value / modulus) * modulus
