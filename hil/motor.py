"""The PM synchronous motor of Table I of the paper, shared by the predictions and the simulation.

It lives outside ``hil.model`` and ``hil.sim`` because both need the same nameplate, and neither
may import the other (see design.md, section 2).
"""

from __future__ import annotations

import math
from dataclasses import dataclass


#: How a back-EMF constant Ke can be stated, and the factor from Ke to the peak line-to-neutral
#: EMF per mechanical rad/s.
KE_DEFINITIONS: dict[str, float] = {
    "rms_phase": math.sqrt(2.0),                     # RMS line-to-neutral
    "peak_phase": 1.0,                               # peak line-to-neutral
    "rms_line": math.sqrt(2.0) / math.sqrt(3.0),     # RMS line-to-line
    "peak_line": 1.0 / math.sqrt(3.0),               # peak line-to-line
}
#: Table I's default reading (evidence in hil/model/README.md, "Ke's definition").
TABLE_I_KE_DEFINITION = "rms_phase"


@dataclass(frozen=True)
class MotorParameters:
    """Nameplate of a sinusoidal-EMF PMSM; defaults are Table I of the paper (SI units).

    ``ke_v_s_per_rad`` is the back-EMF constant as stated (Table I: 0.023 V/(rad/s), per
    mechanical rad/s) and ``ke_definition`` says how: ``rms_phase``, ``peak_phase``, ``rms_line``
    or ``peak_line`` (``KE_DEFINITIONS``). Everything else uses the one conversion here: the peak
    phase EMF per mechanical rad/s ``emf_peak_v_s_per_rad`` (E = that × ω_m, paper eq 1), the
    peak phase flux linkage ψ = E/ω_e, and the torque constant (3/2)·E/ω_m for a peak phase
    current in phase with the EMF.
    """

    pole_count: int = 4
    dc_bus_v: float = 12.0
    phase_resistance_ohm: float = 55e-3
    phase_inductance_h: float = 38.5e-6
    max_reactance_ohm: float = 22.5e-3
    ke_v_s_per_rad: float = 0.023
    ke_definition: str = TABLE_I_KE_DEFINITION

    def __post_init__(self) -> None:
        if self.pole_count < 2 or self.pole_count % 2:
            raise ValueError(f"pole_count must be an even number >= 2, got {self.pole_count}")
        for name in ("dc_bus_v", "phase_resistance_ohm", "phase_inductance_h",
                     "max_reactance_ohm", "ke_v_s_per_rad"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        if self.ke_definition not in KE_DEFINITIONS:
            raise ValueError(f"ke_definition must be one of {', '.join(KE_DEFINITIONS)}, "
                             f"got {self.ke_definition!r}")

    @property
    def pole_pairs(self) -> int:
        return self.pole_count // 2

    @property
    def emf_peak_v_s_per_rad(self) -> float:
        """Peak line-to-neutral EMF per mechanical rad/s (√2·Ke for Table I's RMS-phase Ke)."""
        return KE_DEFINITIONS[self.ke_definition] * self.ke_v_s_per_rad

    @property
    def emf_rms_v_s_per_rad(self) -> float:
        """RMS line-to-neutral EMF per mechanical rad/s (the phasor circuit of eq 27)."""
        return self.emf_peak_v_s_per_rad / math.sqrt(2.0)

    @property
    def flux_linkage_wb(self) -> float:
        """Peak phase flux linkage of the magnets, ψ = E/ω_e (V·s per electrical rad)."""
        return self.emf_peak_v_s_per_rad / self.pole_pairs

    @property
    def torque_constant_nm_per_a(self) -> float:
        """Torque per ampere of peak phase current in phase with the EMF: (3/2)·E/ω_m."""
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
