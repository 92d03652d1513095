"""The engine's results do not depend on which compiled function numba built first.

numba lets a function that does not state ``fastmath`` inherit the flags of the function being
compiled when it is first needed: a firmware helper compiled inside the fast-math engine would
get fast-math, the same helper compiled on its own would not, and the engine then links
whichever version exists. Each subprocess here starts with an empty numba cache (its own
``NUMBA_CACHE_DIR``); one first compiles the firmware functions on their own, the other goes
straight to the engine. The word-length scenario makes every product and sum a truncation
decision, so any difference in arithmetic shows up in the compare values and the currents.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from numba.core.registry import CPUDispatcher as Dispatcher

from hil.sim import electrical, firmware, kernel

SCENARIO = """
import sys
import numpy as np
if {precompile}:
    from hil.sim import firmware, kernel
    from hil.sim.layout import N_PARAMS, N_STATE
    firmware.qfix(0.3, 2.0 ** -9)
    firmware.adc_read(1.0, 0.0, 0.0, 100.0, 2048.0)
    params = np.zeros(N_PARAMS) + 1.0
    firmware.firmware_step(1.0, -0.5, 0.1, 50.0, params, np.zeros(N_STATE), 2000.0,
                           firmware.firmware_constants(params),
                           np.full((firmware.ANGLE_CACHE_ROWS, 7), -1.0))
    kernel.dyno_speed(np.zeros(N_PARAMS), np.zeros(N_STATE), 0.0, 5e-5)
    from hil.sim import electrical
    orders, amplitudes, phases = np.ones(5), np.ones(5), np.zeros(5)
    lag, basis = np.zeros((5, 3)), np.zeros((5, 6))
    electrical.harmonic_table(np.zeros(N_PARAMS), orders, amplitudes, phases)
    electrical.impedance_angles(np.zeros(N_PARAMS) + 1.0, 50.0, orders, amplitudes, 1, lag)
    electrical.period_basis(np.zeros(N_PARAMS) + 1.0, 0.2, orders, amplitudes, phases, 1, lag,
                            basis)
from hil.motor import MotorParameters
from hil.sim import DriveConfig, Injection, MotorModel, simulate
injection = Injection(word_length_bits=10, ia_offset_a=0.3, ib_gain_error_pu=0.02,
                      dead_time_s=1e-6, encoder_decimation=3, current_angle_rad=0.2)
# the motor stated, so the two runs do not depend on Table I's default Ke reading
motor = MotorModel(parameters=MotorParameters(ke_definition="rms_phase"))
result = simulate(DriveConfig(motor=motor, injection=injection, speed_rpm=500.0,
                              current_command_a=20.0), 0.02, 20_000)
np.savez(sys.argv[1], **{{name: result[name] for name in
                          ("ia_a", "ib_a", "ic_a", "va_v", "vb_v", "vc_v", "torque_em_nm",
                           "id_a", "iq_a")}})
"""


def _start(tmp_path: Path, precompile: bool) -> tuple[subprocess.Popen, Path, Path]:
    """The scenario in a subprocess with an empty numba cache of its own: (process, output,
    its standard error's file)."""
    label = "firmware-first" if precompile else "engine-first"
    cache = tmp_path / f"numba-cache-{label}"
    cache.mkdir()
    output, errors = tmp_path / f"{label}.npz", tmp_path / f"{label}.stderr"
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache))
    with errors.open("w") as stderr:
        process = subprocess.Popen([sys.executable, "-c", SCENARIO.format(precompile=precompile),
                                    str(output)], env=env, stdout=subprocess.DEVNULL,
                                   stderr=stderr)
    return process, output, errors


def _result(process: subprocess.Popen, output: Path, errors: Path) -> dict[str, np.ndarray]:
    assert process.wait(timeout=600) == 0, errors.read_text()[-3000:]
    with np.load(output) as data:
        return {name: data[name] for name in data.files}


@pytest.mark.timeout(900)
def test_firmware_compiled_first_gives_the_same_bits(tmp_path):
    # the two cold compiles (~23 s of CPU each) side by side: each has its own cache folder,
    # so neither can load what the other compiled
    started = [_start(tmp_path, precompile=False), _start(tmp_path, precompile=True)]
    try:
        engine_first, firmware_first = (_result(*run) for run in started)
    finally:
        for process, _, _ in started:
            if process.poll() is None:
                process.kill()
    for name, values in engine_first.items():
        other = firmware_first[name]
        differing = np.flatnonzero(values != other)
        worst = np.abs(values - other).max() if differing.size else 0.0
        assert differing.size == 0, (f"{name}: {differing.size} of {values.size} samples differ, "
                                     f"first at {differing[:1]}, worst by {worst:.3g}")


def _dispatchers(module):
    return [value for value in vars(module).values()
            if isinstance(value, Dispatcher) and value.py_func.__module__ == module.__name__]


@pytest.mark.parametrize("module", [electrical, firmware, kernel], ids=lambda m: m.__name__)
def test_every_compiled_function_states_its_fastmath_flags(module):
    # a function that states nothing inherits its first caller's flags (the cause above)
    dispatchers = _dispatchers(module)
    assert dispatchers
    for dispatcher in dispatchers:
        assert "fastmath" in dispatcher.targetoptions, dispatcher.py_func.__name__
        if module is firmware:
            assert dispatcher.targetoptions["fastmath"] is False, dispatcher.py_func.__name__
