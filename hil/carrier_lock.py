"""The dyno's speed kept off a PWM carrier locked to the rotor.

At a speed where the PWM periods per electrical revolution r = f_pwm/f_e are a whole number (or
close to a simple fraction), every revolution puts the carrier at the same rotor angles: the
drive's per-period quantisation pattern (word length, PWM resolution, dead time) becomes
synchronous, the synchronous average keeps it whole, and its size depends on the carrier's phase
when the drive was enabled — on the bench's history. The models (and the paper's eqs) average
over the carrier's phase. Measured on the twin, Table I 1200 rpm (r = 500), 10 A, the warm
loop of the deviation study: word length 8/10/12 bits read 1.18/1.08/1.28× their models at
1200 rpm and 1.03/0.91/0.97× at 1200.18 rpm (1.01/0.93/0.84× at 1201.3), and the same 12-bit
point read 1.8× after the other plans had run.

A real bench's dyno and drive run on separate clocks, so an exact lock does not last; the
simulated dyno's speed is exact. :func:`unlocked_speed_rpm` therefore moves the dyno's speed by
the least fraction (≤ ``MAX_NUDGE_PU``) at which the carrier's phase at the start of each
analysed period (m electrical revolutions), n·m·r mod 1, leaves no gap wider than
``MAX_PHASE_GAP_PERIODS``. The record keeps the dyno's setpoint beside the point's nominal speed,
and says where no such move exists (:func:`carrier_locked`).
"""

from __future__ import annotations

import numpy as np

#: The widest gap, in PWM periods, the analysed periods' carrier phases may leave; a capture of n
#: periods cannot leave less than 1/n, so it may leave 1.5/n.
MAX_PHASE_GAP_PERIODS = 0.25
#: The largest relative change of speed that may be made (0.5 %), and its step.
MAX_NUDGE_PU = 5e-3
NUDGE_STEP_PU = 1e-5


def carrier_phase_gap(periods_per_revolution: float, revolutions: int) -> float:
    """Widest gap, in PWM periods, between the carrier phases n·r mod 1 of ``revolutions``
    consecutive revolutions (1.0: locked, every revolution at the same phase)."""
    phases = np.sort(np.mod(np.arange(revolutions) * periods_per_revolution, 1.0))
    gaps = np.diff(np.concatenate([phases, [phases[0] + 1.0]]))
    return float(gaps.max())


def _walks(speed_rpm: float, pole_pairs: int, pwm_hz: float, revolutions: int,
           period_revolutions: int) -> bool:
    """Whether the carrier's phase at the start of each of the ``revolutions`` analysed periods
    (``period_revolutions`` electrical revolutions each: the synchronous average groups by them)
    leaves no gap wider than the limit."""
    f_e = abs(speed_rpm) / 60.0 * pole_pairs
    per_period = pwm_hz * period_revolutions / f_e
    return carrier_phase_gap(per_period, revolutions) <= max(MAX_PHASE_GAP_PERIODS,
                                                             1.5 / revolutions)


def unlocked_speed_rpm(speed_rpm: float, pole_pairs: int, pwm_hz: float, revolutions: int,
                       period_revolutions: int = 1) -> float:
    """``speed_rpm`` itself where the carrier walks over the captured periods, else the nearest
    speed (within ±``MAX_NUDGE_PU``, the slower first: it keeps the voltage headroom and the
    bench's speed limit the pre-flight checked) where it does; ``speed_rpm`` if there is none
    (:func:`carrier_locked` then says so)."""
    if speed_rpm == 0.0 or revolutions < 2:
        return speed_rpm
    steps = np.arange(1, int(round(MAX_NUDGE_PU / NUDGE_STEP_PU)) + 1) * NUDGE_STEP_PU
    for scale in np.concatenate([[0.0], np.ravel(np.column_stack([-steps, steps]))]):
        moved = speed_rpm * (1.0 + float(scale))
        if _walks(moved, pole_pairs, pwm_hz, revolutions, period_revolutions):
            return moved
    return speed_rpm


def carrier_locked(speed_rpm: float, pole_pairs: int, pwm_hz: float, revolutions: int,
                   period_revolutions: int = 1) -> bool:
    """Whether the carrier stays locked at ``speed_rpm`` (no move within ±0.5 % unlocks it)."""
    if speed_rpm == 0.0 or revolutions < 2:
        return False
    return not _walks(speed_rpm, pole_pairs, pwm_hz, revolutions, period_revolutions)
