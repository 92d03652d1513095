"""What the bench adds to a predicted order phase, and how well it is known (issue 21 item 4).

The closed forms (eqs 19, 25) give the ripple as a function of the electrical angle θ under
ideal current regulation and an ideal transducer. What the bench measures, an order-k phase in
the analysis' convention τ = c₀ + Σ A_k·cos(kθ + φ_k) (θ the true electrical angle in either
direction of rotation), differs by:

* **the transducer's response**, a first-order low-pass of the bench file's ``[torque]
  bandwidth_hz`` f_t: at the order's frequency f_k = k·|f_e| the reading lags by atan(f_k/f_t) in
  time, which is −sign(ω_e)·atan(f_k/f_t) in θ (a lag in time is a shift back along the angle the
  rotor travels). Applied as a correction; the bench file states no tolerance on f_t, so the
  correction is counted once more as its own uncertainty bound;
* **the current loop**: the loop regulates the measured currents with the bench file's bandwidth
  f_c and delay τ_d, so the actual current error follows the sensor error with a lag bounded by
  atan(f_k/f_c) + 2π·f_k·τ_d; not corrected (its sign depends on the disturbance's sequence),
  counted as a bound;
* **the angle reference**: the angle channel's resolution (half a count, electrical), a bound.

The bounds are added linearly (worst case): the model's phase uncertainty ``U_model``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class ChainPhase:
    """The bench's phase at one order: the correction to add to a model phase and its bounds
    (rad, in the analysis' θ convention)."""

    order: int
    frequency_hz: float
    correction_rad: float
    bounds_rad: dict

    @property
    def model_u_rad(self) -> float:
        """Linear sum of the bounds (worst case)."""
        return float(sum(self.bounds_rad.values()))

    def to_dict(self) -> dict:
        return {"order": self.order, "frequency_hz": self.frequency_hz,
                "correction_rad": self.correction_rad, "bounds_rad": dict(self.bounds_rad),
                "model_u_rad": self.model_u_rad}


def transducer_phase_rad(frequency_hz: float, bandwidth_hz: float | None) -> float:
    """Time-domain lag of a first-order transducer of bandwidth f_t at f (rad, ≥ 0); 0 when the
    bandwidth is not stated (then it is unknown, and the caller must say so)."""
    return 0.0 if not bandwidth_hz else math.atan(frequency_hz / bandwidth_hz)


def chain_phase(order: int, speed_rpm: float, pole_pairs: int, *,
                transducer_bandwidth_hz: float | None,
                loop_bandwidth_hz: float | None, loop_delay_s: float | None,
                angle_counts_per_rev: int | None) -> ChainPhase:
    """The transducer correction and the model's phase bounds at electrical order ``order``."""
    electrical_hz = speed_rpm / 60.0 * pole_pairs
    frequency_hz = abs(order * electrical_hz)
    direction = 1.0 if electrical_hz >= 0 else -1.0
    transducer = transducer_phase_rad(frequency_hz, transducer_bandwidth_hz)
    loop = 0.0
    if loop_bandwidth_hz:
        loop += math.atan(frequency_hz / loop_bandwidth_hz)
    if loop_delay_s:
        loop += 2.0 * math.pi * frequency_hz * loop_delay_s
    angle = math.pi * pole_pairs / angle_counts_per_rev if angle_counts_per_rev else 0.0
    return ChainPhase(order=int(order), frequency_hz=frequency_hz,
                      correction_rad=-direction * transducer,
                      bounds_rad={"transducer (stated bandwidth, no tolerance stated)": transducer,
                                  "current loop lag (stated bandwidth and delay)": loop,
                                  "angle reference (half a count, electrical)": angle})


def wrap_rad(angle_rad: float) -> float:
    """``angle_rad`` wrapped into (−π, π]."""
    wrapped = math.remainder(angle_rad, 2.0 * math.pi)
    return math.pi if wrapped == -math.pi else wrapped
