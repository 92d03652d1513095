"""Instrumentation of the twin, one row per PWM period (for studies and tests, not the bench).

``period_trace`` steps the compiled engine one period at a time and records what the firmware
decided and what the inverter could do: the compare values it applied, the compare values the
loop *asked for* before the modulator's duty limit and pulse dropping (``firmware._compare``),
the PI integrators, the phase currents at the period start. This is how the twin's "cliffs" were
found to be a duty-limit limit cycle (see ``hil/sim/README.md``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hil.sim import layout as L
from hil.sim.config import DriveConfig
from hil.sim.firmware import (ANGLE_CACHE_ROWS, A_INDEX, K_MAX_COMPARE, firmware_constants,
                              firmware_step)
from hil.sim.kernel import run_drive
from hil.sim.packing import new_state, pack_params
from hil.sim.results import NO_LATEST, NO_ROWS, NO_SAMPLES



@dataclass(frozen=True)
class PeriodTrace:
    """Per PWM period k (rows), from ``period_trace``.

    ``compare``: the three compare values (counts) applied in period k; ``demanded``: what the
    current loop asked for in period k before the modulator's limits, counts (may exceed
    ``max_compare``); ``currents_a``: phase currents at the start of period k, A;
    ``integrators_v``: the d and q PI integrators after the firmware ran at the start of period
    k, V; ``counts_top``: counter top N; ``max_compare``: the widest pulse the modulator emits
    short of full-on (N·(1 − 2·t_d/T)); a demand above the midpoint between the two becomes
    full-on (no edge, no dead time).
    """

    compare: np.ndarray
    demanded: np.ndarray
    currents_a: np.ndarray
    integrators_v: np.ndarray
    counts_top: float
    max_compare: float

    @property
    def full_on(self) -> np.ndarray:
        """Per period: some leg is full-on although the loop asked for less than N."""
        return ((self.compare >= self.counts_top) & (self.demanded < self.counts_top)).any(axis=1)

    @property
    def clipped(self) -> np.ndarray:
        """Per period: some leg's demand exceeds the modulator's widest pulse."""
        return (self.demanded > self.max_compare).any(axis=1)


def period_trace(config: DriveConfig, settle_s: float, duration_s: float) -> PeriodTrace:
    """Run ``config`` from rest for ``settle_s``, then record ``duration_s`` period by period.

    Only for the firmware's default delay (1 period): the demand of period k is the firmware's
    output at the start of period k − 1.
    """
    if config.firmware.delay_periods != 1.0:
        raise ValueError("period_trace follows the default 1-period loop delay only")
    params = pack_params(config)
    period = 1.0 / params[L.P_PWM_FREQ]
    state = new_state()
    run_drive(params, state, 0.0, period, NO_SAMPLES, NO_ROWS, NO_LATEST, settle_s)
    constants = firmware_constants(params)
    max_compare = float(constants[K_MAX_COMPARE])
    unlimited = constants.copy()                  # the probe: no pulse-width limit
    unlimited[K_MAX_COMPARE] = 2.0 * params[L.P_PWM_COUNTS]
    counts_top = params[L.P_PWM_COUNTS]
    cache = np.empty((ANGLE_CACHE_ROWS, 7))
    cache[:, A_INDEX] = -1.0
    n = int(math.floor(duration_s / period + 1e-9))
    compare = np.zeros((n, 3))
    demanded = np.zeros((n, 3))
    currents = np.zeros((n, 3))
    integrators = np.zeros((n, 2))
    ask = np.full(3, np.nan)
    for k in range(n):
        compare[k] = state[L.S_CMP_A:L.S_CMP_A + 3]
        demanded[k] = ask
        currents[k] = state[L.S_IA:L.S_IA + 3]
        # the loop's unlimited demand from this period's sample (applies next period)
        probe = state.copy()
        ask = np.array(firmware_step(state[L.S_IA], state[L.S_IB], state[L.S_THETA_M],
                                     state[L.S_OMEGA_M], params, probe, counts_top, unlimited,
                                     cache))
        run_drive(params, state, 0.0, period, NO_SAMPLES, NO_ROWS, NO_LATEST,
                  state[L.S_TIME] + 0.5 * period)
        integrators[k] = state[L.S_INT_D:L.S_INT_Q + 1] * params[L.P_VDC]
    return PeriodTrace(compare=compare[1:], demanded=demanded[1:], currents_a=currents[1:],
                       integrators_v=integrators[1:], counts_top=counts_top,
                       max_compare=max_compare)
