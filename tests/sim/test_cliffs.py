"""The twin's dead-time "cliffs" (issue 13 item 5), pinned with the mechanism that makes them.

At 500 rpm / 20 A the ripple jumps between 5.5 and 6 µs of dead time, at 1000 rpm / 20.78 A by
4 µs. Instrumented period by period (``hil.sim.diagnostics``) both are the same duty-limit limit
cycle: the highest leg's demand exceeds the modulator's widest pulse N·(1 − 2·t_d/T) (clipping),
the loop winds up, and once the demand passes N·(1 − t_d/T) that leg goes full-on for a period,
3·t_d/T·V_dc higher, and the current spikes. ``hil.sim.validity`` estimates where clipping
starts; the cliff lies beyond it, where the wound-up demand reaches the full-on threshold.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from hil.motor import MotorParameters
from hil.sim import DriveConfig, Injection, InverterModel, MotorModel, simulate
from hil.sim.diagnostics import period_trace
from hil.sim.validity import duty_headroom

SETTLE_S = 0.05
#: the motor the cliffs were reported with: Table I with Ke read as RMS phase EMF (E = √2·Ke·ω_m);
#: with another reading the EMF, hence the voltage headroom and the cliffs' dead times, differ
MOTOR = MotorModel(parameters=MotorParameters(ke_definition="rms_phase"))


def config(speed_rpm, current_a, dead_time_us, angle_deg=0.0, modulation="svpwm"):
    return DriveConfig(motor=MOTOR, current_command_a=current_a, speed_rpm=speed_rpm,
                       inverter=InverterModel(modulation=modulation),
                       injection=Injection(dead_time_s=dead_time_us * 1e-6,
                                           current_angle_rad=math.radians(angle_deg)))


def trace(cfg, revs=2):
    return period_trace(cfg, SETTLE_S, revs / (2.0 * abs(cfg.speed_rpm) / 60.0))


def torque_pk_pk_pct(cfg, revs=2):
    torque = simulate(cfg, revs / (2.0 * abs(cfg.speed_rpm) / 60.0), 20_000.0,
                      settle_s=SETTLE_S)["torque_em_nm"]
    return np.ptp(torque) / torque.mean() * 100.0


def test_500_rpm_cliff_is_the_first_full_on_period():
    before = trace(config(500.0, 20.0, 5.5))
    assert before.clipped.any() and not before.full_on.any()      # clipped, never full-on
    assert np.abs(before.currents_a).max() < 20.5
    after = trace(config(500.0, 20.0, 6.0))
    assert after.full_on.sum() > 20
    assert np.abs(after.currents_a).max() > 23.0
    # every current spike follows a full-on period (the one before it applies the jump)
    spikes = np.flatnonzero((np.abs(after.currents_a) > 21.5).any(axis=1))
    assert len(spikes) and all(after.full_on[max(k - 2, 0):k].any() for k in spikes)
    assert torque_pk_pk_pct(config(500.0, 20.0, 5.5)) < 3.0
    assert torque_pk_pk_pct(config(500.0, 20.0, 6.0)) > 20.0


def test_1000_rpm_cliff_is_the_same_limit_cycle():
    inside = trace(config(1000.0, 20.78, 2.0))
    assert not inside.clipped.any() and np.abs(inside.currents_a).max() < 21.0
    cliff = trace(config(1000.0, 20.78, 4.0))
    assert cliff.full_on.sum() > 50 and np.abs(cliff.currents_a).max() > 22.5
    assert torque_pk_pk_pct(config(1000.0, 20.78, 2.0)) < 2.0
    assert torque_pk_pk_pct(config(1000.0, 20.78, 4.0)) > 15.0


def test_trace_reproduces_the_modulator_and_full_on_follows_clipping():
    """The instrument's demand, put through the modulator's rule, is what the engine applied;
    and a full-on period always comes after a clipped one (the loop winds up first)."""
    from hil.sim.firmware import _compare

    for cfg in (config(500.0, 20.0, 6.0), config(1000.0, 20.78, 4.0)):
        run = trace(cfg)
        top = run.counts_top
        unlimited = [_compare((d + 0.5) / top - 0.5, top, 2 * top) for d in run.demanded.flat]
        assert np.array_equal(unlimited, run.demanded.ravel())    # demand is whole counts
        limited = [_compare((d + 0.5) / top - 0.5, top, run.max_compare)
                   for d in run.demanded.flat]
        assert np.array_equal(limited, run.compare.ravel())
        assert run.full_on.any() and not (run.full_on & ~np.roll(run.clipped, 1)).any()


@pytest.mark.parametrize("speed_rpm, current_a, angle_deg, modulation, inside_us, outside_us", [
    (500.0, 20.0, 0.0, "svpwm", 4.5, 5.0),
    (1000.0, 20.78, 0.0, "svpwm", 2.5, 3.0),
    (800.0, 15.0, 30.0, "svpwm", 3.5, 4.5),
    (300.0, 25.0, -20.0, "sine", 4.0, 5.0),
])
def test_duty_headroom_says_where_clipping_starts(speed_rpm, current_a, angle_deg, modulation,
                                                  inside_us, outside_us):
    inside = config(speed_rpm, current_a, inside_us, angle_deg, modulation)
    outside = config(speed_rpm, current_a, outside_us, angle_deg, modulation)
    assert duty_headroom(inside) > 0.005 and not trace(inside).clipped.any()
    assert duty_headroom(outside) < -0.005 and trace(outside).clipped.mean() > 0.2
