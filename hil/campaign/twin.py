"""The twin path of campaigns: per-drive pk-pk ripple from the switching-level simulation.

What is measured: the air-gap torque ``torque_em_nm`` of ``hil.sim`` (Σ e_x·i_x/ω_m, no
transducer bandwidth, gain error or noise), sampled ``samples_per_pwm`` times per PWM period,
analysed by ``hil.analysis.analyze_torque`` over ``revolutions`` whole electrical revolutions after
``settle_s``: the pk-pk of the synchronous average band-limited to electrical orders
1..``max_order``, per unit of its mean torque (design.md §3). Switching-frequency ripple is not
synchronous with the rotor and falls outside that band.

Each chunk simulates its drives one after another on one core (``simulate_batch`` with
``parallel=False``): the parallelism is the campaign's workers, not numba threads. Only the
three channels used are simulated, and the analysis skips its uncertainty budget (a campaign
needs the ripple figure only; both leave that figure bit for bit the same).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from hil.analysis import RippleResult, analyze_torque
from hil.campaign.engine import run_campaign
from hil.errors import InputError
from hil.sim import DriveConfig, SimResult, simulate_batch


#: The only channels a campaign drive needs (the twin computes no others).
CHANNELS = ("time_s", "torque_em_nm", "rotor_angle_mech_rad")


@dataclass(frozen=True)
class TwinSettings:
    """How long and how finely each simulated drive is observed."""

    revolutions: int = 2
    settle_s: float = 0.01
    samples_per_pwm: int = 2
    max_order: int = 64

    def __post_init__(self) -> None:
        if not 1 <= self.revolutions <= 1000:
            raise InputError(f"revolutions={self.revolutions!r} must be in 1..1000")
        if not 0.0 <= self.settle_s <= 10.0:
            raise InputError(f"settle_s={self.settle_s!r} must be in [0, 10] s")
        if not 1 <= self.samples_per_pwm <= 16:
            raise InputError(f"samples_per_pwm={self.samples_per_pwm!r} must be in 1..16")

    def duration_s(self, speed_rpm: float, pole_pairs: int) -> float:
        """Simulated time of ``revolutions`` electrical revolutions (plus 1 % margin)."""
        if speed_rpm == 0:
            raise InputError("speed_rpm=0: a ripple over electrical revolutions needs a "
                             "non-zero speed")
        return 1.01 * self.revolutions * 60.0 / (abs(speed_rpm) * pole_pairs)


def simulate_drive(config: DriveConfig, settings: TwinSettings) -> SimResult:
    """One drive's ``CHANNELS``, ``settings.samples_per_pwm`` samples per PWM period over
    ``revolutions`` electrical revolutions after ``settle_s``, on this core."""
    pole_pairs = config.motor.parameters.pole_pairs
    rate_hz = settings.samples_per_pwm * config.injection.pwm_frequency_hz
    return simulate_batch([config], settings.duration_s(config.speed_rpm, pole_pairs), rate_hz,
                          settle_s=settings.settle_s, parallel=False, channels=CHANNELS)[0]


def analyze_drive(result: SimResult, config: DriveConfig, settings: TwinSettings, *,
                  uncertainty_budget: bool = False) -> RippleResult:
    """The air-gap torque of ``simulate_drive`` against the electrical angle, orders
    1..``max_order``; without the uncertainty budget unless asked (module docstring)."""
    return analyze_torque(result["time_s"], result["torque_em_nm"],
                          config.motor.parameters.pole_pairs * result["rotor_angle_mech_rad"],
                          max_order=settings.max_order, uncertainty_budget=uncertainty_budget)


def twin_ripple_pu(configs: Sequence[DriveConfig], settings: TwinSettings = TwinSettings()
                   ) -> np.ndarray:
    """Pk-pk air-gap torque ripple per unit of the mean torque of each drive (module docstring)."""
    return np.array([analyze_drive(simulate_drive(config, settings), config, settings).pk_pk_pu
                     for config in configs], dtype=float)


def configured(base: DriveConfig, point: dict[str, Any]) -> DriveConfig:
    """``base`` with a grid point's values: ``speed_rpm``, ``current_command_a`` or injection
    knobs (``hil.sim.Injection`` names); anything else is an InputError naming the key."""
    top = {k: v for k, v in point.items() if k in ("speed_rpm", "current_command_a")}
    knobs = {k: v for k, v in point.items() if k not in top}
    try:
        injection = base.injection.with_values(**knobs)
        return dataclasses.replace(base, injection=injection, **top)
    except ValueError as exc:
        raise InputError(f"grid point {point}: {exc}") from None


def _map_chunk(spec: tuple[DriveConfig, list[dict], TwinSettings],
               seed: np.random.SeedSequence) -> dict[str, np.ndarray]:
    base, points, settings = spec
    return {"pk_pk_pu": twin_ripple_pu([configured(base, p) for p in points], settings)}


def twin_ripple_map(grid: Sequence[dict[str, Any]], drive_config: DriveConfig, folder: str | Path,
                    *, settings: TwinSettings = TwinSettings(), chunk_size: int = 8,
                    scheduler: str | None = None, n_workers: int | None = None,
                    client: Any = None, progress: bool = True) -> np.ndarray:
    """Twin pk-pk ripple (per unit of the mean torque) at every grid point, on the campaign
    engine: ``grid`` is a list of {speed_rpm | current_command_a | injection knob: value}."""
    points = [dict(p) for p in grid]
    for point in points:
        configured(drive_config, point)  # every point is checked before any work starts
    specs = [(drive_config, points[i:i + chunk_size], settings)
             for i in range(0, len(points), chunk_size)]
    result = run_campaign(_map_chunk, specs, folder, scheduler=scheduler, n_workers=n_workers,
                          client=client, progress=progress, description="twin map",
                          identity={"grid": points, "drive": repr(drive_config),
                                    "settings": dataclasses.asdict(settings)})
    return result.concatenated("pk_pk_pu")
