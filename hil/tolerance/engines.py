"""The two yield engines as campaign chunk tasks: per drive, the pk-pk ripple at every point.

A chunk either samples drives ``start .. start + n`` from the tolerance distributions (Monte
Carlo) or evaluates given parameter rows (Sobol' and inverse-design samples). Drive i is drawn
in block i // 256, whose generator is seeded by ``chunk_seed(seed, block)``: so a drive's
parameters depend on the campaign seed and its index only — not on the chunk size (which differs
between the engines), nor on the workers. Both engines see the same drives for the same seed:

* ``closed-form`` — :func:`hil.tolerance.combiner.ripple_pu`, all drives of the chunk at once.
* ``twin`` — each drive built as a ``hil.sim.DriveConfig`` and simulated
  (:func:`hil.campaign.twin.twin_ripple_pu`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from hil.campaign.seeds import chunk_seed
from hil.campaign.twin import TwinSettings, twin_ripple_pu
from hil.errors import InputError
from hil.model.core import OperatingPoint
from hil.sim import DriveConfig, Injection, SensorModel
from hil.tolerance.combiner import CombinerSettings, ripple_pu
from hil.tolerance.spec import PARAMETERS, ToleranceSpec

ENGINES = ("closed-form", "twin")


@dataclass(frozen=True)
class ChunkJob:
    """One chunk: Monte Carlo drives ``start .. start + n`` of ``spec``, or the given ``rows``."""

    spec: ToleranceSpec
    engine: str
    n: int = 0
    start: int = 0
    rows: dict[str, np.ndarray] | None = field(default=None, compare=False)
    combiner: CombinerSettings = CombinerSettings()
    twin: TwinSettings = TwinSettings()

    def __post_init__(self) -> None:
        if self.engine not in ENGINES:
            raise InputError(f"engine {self.engine!r} (allowed: {', '.join(ENGINES)})")


def sample_parameters(spec: ToleranceSpec, rng: np.random.Generator, n: int
                      ) -> dict[str, np.ndarray]:
    """Draw ``n`` drives; parameters in the fixed order of ``PARAMETERS`` (fixed ones draw none)."""
    return {name: spec.parameters[name].sample(rng, n) for name in PARAMETERS}


#: Drives drawn per generator (module docstring).
DRIVE_BLOCK = 256


def sample_drives(spec: ToleranceSpec, start: int, n: int) -> dict[str, np.ndarray]:
    """Parameters of drives ``start .. start + n`` of the campaign (block-seeded, see above)."""
    first, last = start // DRIVE_BLOCK, (start + n - 1) // DRIVE_BLOCK
    blocks = [sample_parameters(spec, np.random.default_rng(chunk_seed(spec.seed, b)),
                                DRIVE_BLOCK) for b in range(first, last + 1)]
    offset = start - first * DRIVE_BLOCK
    return {name: np.concatenate([block[name] for block in blocks])[offset:offset + n]
            for name in PARAMETERS}


def parameters_from_unit(spec: ToleranceSpec, unit: dict[str, np.ndarray], n: int
                         ) -> dict[str, np.ndarray]:
    """Parameters from uniforms u ∈ [0, 1) per varied parameter (inverse CDF); others fixed."""
    return {name: (spec.parameters[name].ppf(unit[name]) if name in unit
                   else spec.parameters[name].ppf(np.full(n, 0.5)))
            for name in PARAMETERS}


def closed_form_ripple(ops: tuple[OperatingPoint, ...], params: dict[str, np.ndarray], n: int,
                       settings: CombinerSettings = CombinerSettings()) -> np.ndarray:
    """(n, points) pk-pk per unit of the mean torque, closed form."""
    return np.stack([ripple_pu(op, params, n, settings) for op in ops], axis=1)


def drive_config(op: OperatingPoint, row: dict[str, float]) -> DriveConfig:
    """The simulated drive of one parameter row at one operating point."""
    knobs = {name: row[name] for name in ("ia_offset_a", "ib_offset_a", "ia_gain_error_pu",
                                          "ib_gain_error_pu", "dead_time_s", "pwm_frequency_hz")}
    injection = Injection(**{k: float(v) for k, v in knobs.items()},
                          encoder_decimation=int(row["encoder_decimation"]),
                          hall_mode=bool(row["hall_mode"] > 0.5),
                          word_length_bits=int(row["word_length_bits"]),
                          pwm_period_counts=int(row["pwm_period_counts"]),
                          current_angle_rad=op.current_angle_rad)
    return DriveConfig(sensors=SensorModel(encoder_counts_per_rev=int(row["encoder_counts_per_rev"])),
                       injection=injection, current_command_a=op.current_a,
                       speed_rpm=op.speed_rpm)


def twin_ripple(ops: tuple[OperatingPoint, ...], params: dict[str, np.ndarray], n: int,
                settings: TwinSettings = TwinSettings()) -> np.ndarray:
    """(n, points) pk-pk per unit of the mean torque, switching-level twin."""
    out = np.empty((n, len(ops)))
    for j, op in enumerate(ops):
        configs = [drive_config(op, {name: params[name][i] for name in PARAMETERS})
                   for i in range(n)]
        out[:, j] = twin_ripple_pu(configs, settings)
    return out


def yield_chunk(job: ChunkJob, seed: np.random.SeedSequence) -> dict[str, np.ndarray]:
    """Campaign task: the chunk's parameters and their ripple (n, points). The chunk's own
    ``seed`` is not used: drives are block-seeded (module docstring)."""
    if job.rows is not None:
        params = {name: np.asarray(job.rows[name], dtype=float) for name in PARAMETERS}
        n = len(params["dead_time_s"])
    else:
        n = job.n
        params = sample_drives(job.spec, job.start, n)
    if job.engine == "closed-form":
        ripple = closed_form_ripple(job.spec.operating_points, params, n, job.combiner)
    else:
        ripple = twin_ripple(job.spec.operating_points, params, n, job.twin)
    return {"ripple_pu": ripple, **{f"param:{name}": params[name] for name in job.spec.varied}}
