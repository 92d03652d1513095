"""Compile every numba kernel a run uses into numba's on-disk cache, once, at install.

``make`` runs it (``python -m hil.sim.warmup``, or ``python -m hil.warmup``); after a bare
``pip install .`` run it once. Without it a first ``hil run`` compiles the twin's engine before
serving its instruments, then the analysis kernels inside its first capture's analysis and the
model kernels inside the first prediction that needs them (issue 33: 59.6 s first run, 34.2 s the
second). Four groups, the numba ones each through the same public entry point a run calls, with the argument
types a run gives them (numba compiles one machine-code version per argument-type signature):

* the project's own modules, byte-compiled (:func:`warm_bytecode`);
* ``hil.sim`` — :func:`hil.sim.warmup.warm_up` (``run_drive``, ``run_batch``);
* ``hil.analysis`` — :func:`hil.analysis.run_analysis` of a short simulated capture laid out as
  the Modbus DAQ driver returns it, with the bench's instrument uncertainty (the block bootstrap)
  and the PWM-switching analysis, and the switching plan's search for a capture rate;
* ``hil.model`` — :func:`hil.model.predict` of every source with each of its models at a Table I
  operating point, and the PWM-resolution noise model the plan calls directly.

``tests/sim/test_warmup_coverage.py`` lists every numba-compiled function in the package and
checks that this warm-up reaches each one.
"""

from __future__ import annotations

import time

#: Operating point of the warm-up captures (any point the plans use would do).
SPEED_RPM = 500.0
CURRENT_A = 20.0
REVOLUTIONS = 4          # >= 2 whole revolutions: the type-A bootstrap runs
SAMPLE_RATE_HZ = 20_000.0
#: The switching analysis needs many samples per PWM period at a rate that is no multiple of it
#: (the simulated DAQ's 200 kS/s, a little lower).
SWITCHING_SAMPLE_RATE_HZ = 197_000.0
PWM_FREQUENCY_HZ = 20_000.0


def _capture(sample_rate_hz: float):
    """A short twin capture with the channels, dtypes and meta the Modbus DAQ driver gives."""
    import math

    import numpy as np

    from hil.capture import Capture
    from hil.motor import TABLE_I
    from hil.sim import DriveConfig, simulate

    electrical_hz = TABLE_I.pole_pairs * SPEED_RPM / 60.0
    sim = simulate(DriveConfig(current_command_a=CURRENT_A, speed_rpm=SPEED_RPM),
                   REVOLUTIONS / electrical_hz, sample_rate_hz, settle_s=0.02)
    counts_per_rev = 4096
    counts = np.floor(sim["rotor_angle_mech_rad"] * counts_per_rev / (2 * math.pi))
    channels = {"time_s": np.arange(len(counts)) / sample_rate_hz,
                "torque_nm": np.asarray(sim["torque_nm"], dtype=np.float64),
                "rotor_angle_mech_rad": counts * (2 * math.pi / counts_per_rev)}
    for name in ("ia_a", "ib_a"):
        channels[name] = np.asarray(sim[name], dtype=np.float64)
    return Capture(channels=channels, meta={"source": "daq", "sample_rate_hz": sample_rate_hz,
                                            "pole_pairs": TABLE_I.pole_pairs,
                                            "encoder_counts_per_rev": counts_per_rev})


def warm_analysis() -> None:
    """Both analyses a plan can ask for, on a DAQ-shaped capture (bootstrap included)."""
    from dataclasses import fields

    from hil.analysis import run_analysis
    from hil.config import default_sim_bench
    from hil.motor import TABLE_I

    instruments = default_sim_bench().instrument_uncertainty()
    torque = {"analysis": "torque", "max_order": 48, "named_order": 6,
              "pole_pairs": TABLE_I.pole_pairs}
    switching = {"analysis": "switching", "max_order": 48, "pwm_frequency_hz": PWM_FREQUENCY_HZ,
                 "motor": {f.name: getattr(TABLE_I, f.name) for f in fields(TABLE_I)}}
    run_analysis(_capture(SAMPLE_RATE_HZ), torque, instruments=instruments)
    run_analysis(_capture(SWITCHING_SAMPLE_RATE_HZ), switching, instruments=instruments)
    # the PWM-switching plan's pre-flight search for a capture rate
    from hil.analysis.switching import effective_samples_per_period

    effective_samples_per_period(SWITCHING_SAMPLE_RATE_HZ, PWM_FREQUENCY_HZ, 2)


#: Parameters a source's prediction needs beyond the operating point (typical plan values).
SOURCE_PARAMETERS = {"word_length": {"word_length_bits": 12},
                     "dead_time": {"dead_time_s": 1e-6},
                     "pwm_resolution": {"pwm_bits": 10}}


def warm_model() -> None:
    """Every source's prediction, with each of its models, at one operating point and the
    default simulated bench's current loop (the numba kernels sit behind the derived models)."""
    import importlib
    import inspect

    from hil.config import default_sim_bench
    from hil.model import SOURCES, OperatingPoint, predict, source_parameters
    from hil.motor import TABLE_I

    drive = default_sim_bench().drive
    loop = {"current_loop_bandwidth_hz": drive.current_loop_equivalent_bandwidth_hz(),
            "current_loop_delay_s": drive.current_loop_delay_s}
    op = OperatingPoint(speed_rpm=SPEED_RPM, current_a=CURRENT_A, motor=TABLE_I)
    for source, function in SOURCES.items():
        accepted = source_parameters(source)
        params = SOURCE_PARAMETERS.get(source, {}) | {k: v for k, v in loop.items()
                                                      if k in accepted}
        models = getattr(importlib.import_module(function.__module__), "MODELS", None)
        for model in models if models and "model" in accepted else (None,):
            extra = {} if model is None else {"model": model}
            if "max_order" in inspect.signature(function).parameters:
                extra["max_order"] = 48
            predict(source, op, **params, **extra)
    # the PWM-resolution plan's noise check calls the noise model directly
    from hil.model.pwm_noise import predict_noise

    predict_noise(op, 2000, pwm_frequency_hz=PWM_FREQUENCY_HZ, revolutions=REVOLUTIONS,
                  transducer_bandwidth_hz=default_sim_bench().torque.bandwidth_hz,
                  max_order=48, **loop)


#: The project's top-level packages (the importable names ``pyproject.toml`` maps).
PACKAGES = ("hil", "ripple_hil_drivers", "ripple_hil_fixtures", "ripple_hil_testplans",
            "ripple_hil_reports")


def warm_bytecode() -> None:
    """Byte-compile the project's own modules into their ``__pycache__``. ``pip install .``
    does it for an installed copy; an editable install (``make``) never does, and where the
    environment sets ``PYTHONDONTWRITEBYTECODE`` (as this project's CI machine does) every run
    would compile ~240 modules from source again (0.5 s of each ``hil run``). ``compileall``
    writes them whatever that variable says; Python reads them whatever it says."""
    import compileall
    import importlib.util

    for package in PACKAGES:
        for folder in importlib.util.find_spec(package).submodule_search_locations:
            compileall.compile_dir(folder, quiet=1)


def warm_up() -> dict[str, float]:
    """Wall seconds per group (compile, or load from numba's cache)."""
    from hil.sim.warmup import warm_up as warm_sim

    start = time.perf_counter()
    warm_bytecode()
    seconds = {"bytecode": time.perf_counter() - start}
    seconds |= {f"hil.sim {name}": wall_s for name, wall_s in warm_sim().items()}
    for name, step in (("hil.analysis", warm_analysis), ("hil.model", warm_model)):
        start = time.perf_counter()
        step()
        seconds[name] = time.perf_counter() - start
    return seconds


def main() -> None:
    start = time.perf_counter()
    for name, wall_s in warm_up().items():
        print(f"{name}: compiled or loaded in {wall_s:.1f} s", flush=True)
    print(f"warm-up: {time.perf_counter() - start:.1f} s in all")


if __name__ == "__main__":
    main()
