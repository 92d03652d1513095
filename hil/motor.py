"""The PM synchronous motor of Table I of the paper, shared by the predictions and the simulation.

It lives outside ``hil.model`` and ``hil.sim`` because both need the same nameplate, and neither
may import the other (see design.md, section 2).
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class MotorParameters:
    """Nameplate of a sinusoidal-EMF PMSM; defaults are Table I of the paper (SI units).

    ``ke_v_s_per_rad`` is the back-EMF constant of Table I, 0.023 V/(rad/s): the RMS
    line-to-neutral EMF per mechanical rad/s. Eq. (27) uses it that way (RMS phase voltage V and
    torque 3·Ke·I_active), so the EMF amplitude is E = sqrt(2)·Ke·ω_m and the torque constant for
    a peak phase current I in phase with the EMF is (3/2)·sqrt(2)·Ke.
    """

    pole_count: int = 4
    dc_bus_v: float = 12.0
    phase_resistance_ohm: float = 55e-3
    phase_inductance_h: float = 38.5e-6
    max_reactance_ohm: float = 22.5e-3
    ke_v_s_per_rad: float = 0.023

    def __post_init__(self) -> None:
        if self.pole_count < 2 or self.pole_count % 2:
            raise ValueError(f"pole_count must be an even number >= 2, got {self.pole_count}")
        for name in ("dc_bus_v", "phase_resistance_ohm", "phase_inductance_h",
                     "max_reactance_ohm", "ke_v_s_per_rad"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")

    @property
    def pole_pairs(self) -> int:
        return self.pole_count // 2

    @property
    def emf_peak_v_s_per_rad(self) -> float:
        """Peak line-to-neutral EMF per mechanical rad/s: sqrt(2)·Ke."""
        return math.sqrt(2.0) * self.ke_v_s_per_rad

    @property
    def torque_constant_nm_per_a(self) -> float:
        """Torque per ampere of peak phase current in phase with the EMF: (3/2)·sqrt(2)·Ke."""
        return 1.5 * self.emf_peak_v_s_per_rad

    @property
    def max_electrical_speed_rad_s(self) -> float:
        """Electrical speed at which ω_e·L_s reaches the maximum reactance of Table I."""
        return self.max_reactance_ohm / self.phase_inductance_h

    @property
    def max_speed_rpm(self) -> float:
        """Mechanical speed at the maximum reactance of Table I (about 2790 rpm)."""
        return self.max_electrical_speed_rad_s / self.pole_pairs * 60.0 / (2.0 * math.pi)


TABLE_I = MotorParameters()
