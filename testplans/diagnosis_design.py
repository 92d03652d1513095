"""Operating-point design of the diagnosis plan (data, agreed before measuring).

Nothing is injected; the points are chosen so the sources separate (hil.diagnosis):
* two currents (10 A, 20 A peak): gain-mismatch ripple scales with current, cogging does not;
  EMF-harmonic torque scales with current, dead-time torque (in N·m) hardly does;
* two speeds (400, 1000 rpm): the current loop rejects the dead-time harmonics differently at
  each speed, while a motor-side term keeps its amplitude;
* both directions: the dead-time signature's phase follows the direction (the loop's response at
  ±6·ω_e), a term fixed in the rotor angle does not; the transducer's lag flips sign too.
Full factorial, 8 points, current angle φ = 0. Sixteen electrical revolutions per point (eight
mechanical) give the per-revolution scatter for type A; mechanical orders up to 128 are analysed
(an encoder decimated to 56 counts per revolution or more is seen), so the sample rate is
25 kS/s (≥ 11 samples per period of mechanical order 128 at 1000 rpm).
"""

from __future__ import annotations

from dataclasses import dataclass

CURRENTS_A = (10.0, 20.0)
SPEEDS_RPM = (400.0, 1000.0)
DIRECTIONS = (1, -1)
CURRENT_ANGLE_RAD = 0.0
REVOLUTIONS_ELEC = 16
MAX_MECH_ORDER = 128
SAMPLE_RATE_HZ = 25_000.0
SETTLE_S = 0.05


@dataclass(frozen=True)
class DesignPoint:
    speed_rpm: float
    current_a: float
    current_angle_rad: float = CURRENT_ANGLE_RAD

    @property
    def label(self) -> str:
        return f"{self.speed_rpm:+g} rpm, {self.current_a:g} A"

    @property
    def test_id(self) -> str:
        return f"diagnosis[{self.speed_rpm:+g}rpm-{self.current_a:g}A]"


def design_points() -> list[DesignPoint]:
    """The full-factorial design: currents × speeds × directions."""
    return [DesignPoint(speed_rpm=direction * speed, current_a=current)
            for direction in DIRECTIONS for speed in SPEEDS_RPM for current in CURRENTS_A]


def capture_duration_s(point: DesignPoint, pole_pairs: int) -> float:
    """Whole electrical revolutions plus a quarter (as hil.measurement does)."""
    return (REVOLUTIONS_ELEC + 0.25) / (abs(point.speed_rpm) / 60.0 * pole_pairs)
