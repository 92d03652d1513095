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

Standard additions (issue 23 item 1, hil.diagnosis.additions): 12 more points at ±1000 rpm with
one KNOWN addition each, made through the drive's injection knobs (the ones the dc-offset, gain
and dead-time plans use), against the base points of the same speed and current:
* 20 A: +0.2 A and +0.4 A on sensor a, the same on sensor b (the offset transfers at order 1; two
  sizes check linearity); +1 % and +2 % gain on sensor a (order 2); +0.5 µs and +1 µs dead time
  (order 6; on the twin the transfer stays linear to 2 µs at ±1000 rpm, 20 A, and breaks beyond:
  small steps leave room for the drive's own dead time);
* 10 A: +1 % gain on sensor a (a second current separates the gain's torque from cogging);
* −1000 rpm, 20 A: +1 µs dead time (the reverse direction separates the dead time's torque from a
  torque fixed in the rotor angle);
* −1000 rpm, 20 A and 10 A: +1 % gain on sensor a: the gain's estimate gets residual degrees of
  freedom (5 instead of 1), so an order-2 torque in the base that is neither the gain nor
  cogging widens its uncertainty instead of moving it unseen (an 8-pole twin at 1000 rpm carries
  ≈ 0.1 mN·m of it, 5× its type-A σ, with a different phase at 10 and 20 A).
1000 rpm: the shortest captures of the design (bench time) and the larger dead-time signal.

Repeated bases (``repeat_points``): each additions point's base is captured once more after the
additions, nothing injected. The two bases' scatter, pooled over the four points, is the
between-capture reproducibility no single capture's revolution scatter holds
(hil.diagnosis.reproducibility): at 1000 rpm and 20 kHz on an 8-pole motor the PWM carrier and
the rotor are locked (300 periods per electrical revolution), and where they sit when a capture
starts moved the base's order-6 coefficient by several of its type-A σ.
"""

from __future__ import annotations

from dataclasses import dataclass

from hil.diagnosis.additions import INJECTION_KNOBS

CURRENTS_A = (10.0, 20.0)
SPEEDS_RPM = (400.0, 1000.0)
DIRECTIONS = (1, -1)
CURRENT_ANGLE_RAD = 0.0
REVOLUTIONS_ELEC = 16
MAX_MECH_ORDER = 128
SAMPLE_RATE_HZ = 25_000.0
SETTLE_S = 0.05


#: the drive's injection knob that makes each addition (hil.sim.injection names)
ADDITION_KNOBS = INJECTION_KNOBS
ADDITION_SPEED_RPM = 1000.0
#: (speed rpm, current A, addition key, value in the key's unit)
ADDITIONS = (
    (1000.0, 20.0, "addition_ia_offset_a", 0.2), (1000.0, 20.0, "addition_ia_offset_a", 0.4),
    (1000.0, 20.0, "addition_ib_offset_a", 0.2), (1000.0, 20.0, "addition_ib_offset_a", 0.4),
    (1000.0, 20.0, "addition_gain_a_pu", 0.01), (1000.0, 20.0, "addition_gain_a_pu", 0.02),
    (1000.0, 20.0, "addition_dead_time_s", 0.5e-6), (1000.0, 20.0, "addition_dead_time_s", 1e-6),
    (1000.0, 10.0, "addition_gain_a_pu", 0.01),
    (-1000.0, 20.0, "addition_dead_time_s", 1e-6),
    (-1000.0, 20.0, "addition_gain_a_pu", 0.01), (-1000.0, 10.0, "addition_gain_a_pu", 0.01),
)


@dataclass(frozen=True)
class DesignPoint:
    speed_rpm: float
    current_a: float
    current_angle_rad: float = CURRENT_ANGLE_RAD
    #: one known addition (key of hil.diagnosis.additions, value), or None for a base point
    addition: tuple[str, float] | None = None
    #: a base point captured again after the additions (its reproducibility)
    repeat: bool = False

    @property
    def _addition_text(self) -> str:
        if self.addition is None:
            return ""
        key, value = self.addition
        if key == "addition_dead_time_s":
            return f"+{value * 1e6:g}us dead time"
        if key == "addition_gain_a_pu":
            return f"+{100 * value:g}pct gain a"
        return f"+{value:g}A on sensor {key[10]}"

    @property
    def label(self) -> str:
        return f"{self.speed_rpm:+g} rpm, {self.current_a:g} A" + (
            f", {self._addition_text}" if self.addition else "") + (
            ", repeated" if self.repeat else "")

    @property
    def test_id(self) -> str:
        return f"diagnosis[{self.speed_rpm:+g}rpm-{self.current_a:g}A]"

    @property
    def injection(self) -> dict:
        """The drive's injection knobs for this point ({} for a base point): sensor a's gain
        knob multiplies its gain by (1 + value) on a drive with no gain error of its own."""
        if self.addition is None:
            return {}
        key, value = self.addition
        return {ADDITION_KNOBS[key]: value}

    def operating_point(self) -> dict:
        """The dict hil.diagnosis takes (current, angle, label and the addition's key)."""
        op = {"current_a": self.current_a, "current_angle_rad": self.current_angle_rad,
              "label": self.label}
        if self.addition is not None:
            op[self.addition[0]] = self.addition[1]
        return op


def addition_points() -> list[DesignPoint]:
    """The standard-additions points (each against the base point of its speed and current)."""
    return [DesignPoint(speed_rpm=speed, current_a=current, addition=(key, value))
            for speed, current, key, value in ADDITIONS]


def repeat_points() -> list[DesignPoint]:
    """The additions points' bases, captured again after the additions (module docstring)."""
    seen = dict.fromkeys((speed, current) for speed, current, _, _ in ADDITIONS)
    return [DesignPoint(speed_rpm=speed, current_a=current, repeat=True)
            for speed, current in seen]


def design_points() -> list[DesignPoint]:
    """The full-factorial design: currents × speeds × directions."""
    return [DesignPoint(speed_rpm=direction * speed, current_a=current)
            for direction in DIRECTIONS for speed in SPEEDS_RPM for current in CURRENTS_A]


def capture_duration_s(point: DesignPoint, pole_pairs: int) -> float:
    """Whole electrical revolutions plus a quarter (as hil.measurement does)."""
    return (REVOLUTIONS_ELEC + 0.25) / (abs(point.speed_rpm) / 60.0 * pole_pairs)
