"""Plants are plugs (design.md §11, §12.3): who computes the samples behind the simulated
instruments.

:class:`Plant` is the contract the simulated CiA 402 drive, Modbus DAQ and serial transducer
(``drivers/simulated/``) use of the drive they serve; ``hil.sim.DriveTwin`` satisfies it as it
is. The bench file's ``[simulation] plant`` names the implementation (:data:`PLANTS`);
:func:`make_plant` builds it. The instruments, the protocols and the plans do not know which
plant runs; the record does (the bench file as loaded, and :attr:`Plant.identity` in the
drive's and the DAQ's identity strings).
"""

from __future__ import annotations

import sys

from hil.plants.protocol import Plant, plant_identity

#: ``[simulation] plant`` values: the default ripple-hil twin, or motulator's drive
PLANTS = ("ripple-hil", "motulator")
DEFAULT_PLANT = "ripple-hil"

__all__ = ["DEFAULT_PLANT", "PLANTS", "Plant", "make_plant", "plant_identity"]


def make_plant(config, *, seed: int = 0):
    """The plant a simulated bench file (``hil.config.BenchConfig``) names, built but idle."""
    name = getattr(config, "sim_plant", DEFAULT_PLANT)
    if name == "motulator":
        from hil.errors import InputError

        try:
            import motulator  # noqa: F401
        except ImportError:
            raise InputError(
                f"{config.source}: simulation.plant = \"motulator\" needs motulator in this "
                f"Python ({sys.executable}); run under .venv-motulator/bin/python (made by "
                f".ci/setup-motulator), or start `hil sim-bench --bench FILE -o served.toml` "
                f"there and `hil run --bench served.toml` here") from None
        from hil.plants.motulator_plant import MotulatorPlant

        try:
            return MotulatorPlant.from_bench(config, seed=seed)
        except ValueError as exc:
            raise InputError(f"{config.source}: {exc}") from None
    from hil.sim import DriveTwin
    from hil.sim.defects import DriveDefects
    from hil.simbench import twin_config

    return DriveTwin(twin_config(config), seed=seed,
                     defects=DriveDefects.from_dict(config.sim_defects))


#: wall seconds a capture may take per simulated second, by plant (the DAQ driver's wait): the
#: ripple-hil twin runs faster than real time; motulator's carrier comparison takes ≈ 80 CPU s
#: per simulated second, and on a 2-core host loaded to 37 a 0.3 s capture was not done
#: within 360 s (1000 s per simulated second): a capture waits this long before the bench
#: calls it lost
WALL_S_PER_SIMULATED_S = {"motulator": 5000.0}


def capture_timeout_s(config, duration_s: float, settle_s: float = 0.0) -> float:
    """How long the bench waits for one DAQ capture of ``duration_s`` after ``settle_s``: a
    real bench's or the ripple-hil twin's max(30 s, 10 × duration), longer for a slow plant."""
    base = max(30.0, 10.0 * duration_s)
    if not getattr(config, "simulated", False):
        return base
    factor = WALL_S_PER_SIMULATED_S.get(getattr(config, "sim_plant", DEFAULT_PLANT))
    return base if factor is None else max(base, 60.0 + factor * (duration_s + settle_s))
