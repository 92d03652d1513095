"""The twin's dead-time "cliffs" (issue 13 item 5), instrumented period by period.

For each operating point of the issue and a sweep of dead times, prints: the duty headroom the
steady-state estimate gives (``hil.sim.validity``), the highest compare value the current loop
asked for against the modulator's widest pulse and the full-on threshold, how many periods clip
or go full-on, the d/q integrators' range, the peak phase current and the torque pk-pk over two
electrical revolutions (valley samples, per unit of the mean).

    .venv/bin/python studies/twin_cliffs.py
"""

from __future__ import annotations

import numpy as np

from hil.motor import MotorParameters
from hil.sim import DriveConfig, Injection, MotorModel, simulate
from hil.sim.diagnostics import period_trace
from hil.sim.validity import duty_headroom

POINTS = {  # (speed rpm, current A): dead times, µs
    (500.0, 20.0): (4.0, 4.5, 5.0, 5.5, 5.75, 6.0, 7.0),
    (1000.0, 20.78): (2.0, 2.5, 2.75, 3.0, 3.5, 4.0),
}
SETTLE_S = 0.05
#: Table I with Ke read as RMS phase EMF, the reading the cliffs were reported with
MOTOR = MotorModel(parameters=MotorParameters(ke_definition="rms_phase"))
REVS = 2


def row(speed_rpm: float, current_a: float, dead_time_us: float) -> str:
    config = DriveConfig(motor=MOTOR, current_command_a=current_a, speed_rpm=speed_rpm,
                         injection=Injection(dead_time_s=dead_time_us * 1e-6))
    duration = REVS / (2.0 * speed_rpm / 60.0)
    trace = period_trace(config, SETTLE_S, duration)
    torque = simulate(config, duration, 20_000.0, settle_s=SETTLE_S)["torque_em_nm"]
    n_top = trace.counts_top
    return (f"{speed_rpm:6.0f} {current_a:6.2f} {dead_time_us:5.2f} "
            f"{duty_headroom(config):+8.3f} {np.nanmax(trace.demanded):8.0f} "
            f"{trace.max_compare:6.0f} {0.5 * (trace.max_compare + n_top):6.0f} "
            f"{trace.clipped.sum():6d} {trace.full_on.sum():6d} "
            f"{trace.integrators_v[:, 1].min():6.2f}..{trace.integrators_v[:, 1].max():5.2f} "
            f"{np.abs(trace.currents_a).max():6.2f} {np.ptp(torque) / torque.mean() * 100:7.2f}")


def main() -> None:
    print("  rpm      A  t_d/µs headroom  demand  max_c  full@  clip  full-on  int_q/V      "
          "|i|max/A  pk-pk/%")
    for (speed, current), dead_times in POINTS.items():
        for dead in dead_times:
            print(row(speed, current, dead))


if __name__ == "__main__":
    main()
