"""The characterisation captures' sample rate: a prime near 7919 Hz whose samples fall at
spread-out angles from one electrical revolution to the next.

A prime rate keeps PWM harmonics off steady lines and puts the samples at every phase of the PWM
period (as the self-check's). Per electrical revolution the samples start at the phase
n·frac(f_s/f_e) of a sample (revolution n): where those phases bunch — a whole number of samples
per revolution, or close to a half (a pattern of two revolutions) — the samples fall at the same
angles again and again, the per-revolution scatter no longer shows what the sampling phase does
to the phasor, and the type-A u of R understated the capture-to-capture scatter (Table I,
1200 rpm, 10 A, 8 revolutions at 7919 Hz = 197.975 samples per revolution: the scatter 1.9× u,
the rechecks called 33 of 40 steady windings drifted; the 10-pole 48 V motor at 250 rpm, 5 A at
7927 Hz = 380.496: 5 of 11). The rate chosen leaves no gap between those phases wider than
``MAX_GAP_REVOLUTIONS``/n of a sample over the capture's n revolutions (1/n is the least any
rate can leave).
"""

from __future__ import annotations

import math

import numpy as np

#: The nominal rate, Hz (prime).
SAMPLE_RATE_HZ = 7919.0
#: The widest gap the revolutions' sampling phases may leave, in units of 1/n of a sample.
MAX_GAP_REVOLUTIONS = 2.0
#: How far from ``SAMPLE_RATE_HZ`` a rate may be sought, Hz.
SEARCH_HZ = 1000


def _is_prime(n: int) -> bool:
    return n > 1 and all(n % k for k in range(2, math.isqrt(n) + 1))


def phase_gap(samples_per_revolution: float, revolutions: int) -> float:
    """Widest gap, in samples, between the sampling phases n·x mod 1 of ``revolutions``
    consecutive revolutions (x samples per revolution; 1.0 for a whole number)."""
    phases = np.sort(np.mod(np.arange(revolutions) * samples_per_revolution, 1.0))
    return float(np.diff(np.concatenate([phases, [phases[0] + 1.0]])).max())


def sample_rate_hz(speed_rpm: float, pole_pairs: int, revolutions: int) -> float:
    """The prime nearest ``SAMPLE_RATE_HZ`` whose sampling phases over ``revolutions`` electrical
    revolutions leave no gap wider than ``MAX_GAP_REVOLUTIONS``/``revolutions``; where no prime
    within ``SEARCH_HZ`` does (an electrical frequency of 1/k Hz makes every whole rate a whole
    number of samples per revolution), the one that leaves the narrowest gap."""
    f_e = abs(speed_rpm) / 60.0 * pole_pairs
    if f_e == 0.0 or revolutions < 2:
        return SAMPLE_RATE_HZ
    base = int(SAMPLE_RATE_HZ)
    primes = sorted((rate for rate in range(base - SEARCH_HZ, base + SEARCH_HZ + 1)
                     if _is_prime(rate)), key=lambda rate: (abs(rate - base), rate))
    widest = MAX_GAP_REVOLUTIONS / revolutions
    gaps = {}
    for rate in primes:
        gaps[rate] = phase_gap(rate / f_e, revolutions)
        if gaps[rate] <= widest:
            return float(rate)
    return float(min(primes, key=lambda rate: (gaps[rate], abs(rate - base))))
