"""Study: where the dead time's order-6 torque is linear in T_d on the twin (issue 23 item 1, the
assumption behind the dead-time additions of ``hil.diagnosis.additions``).

Run: ``.venv/bin/python studies/additions_dead_time_linearity.py``. Prints, per operating point
(Table I motor, nothing else injected), the torque coefficient at electrical orders 6 and 12
(mechanical 12, 24) for dead times 0-4 µs: where it is proportional to T_d, the transfer
(torque per µs) is the same at every T_d.
"""

from __future__ import annotations

import numpy as np

from hil.diagnosis.additions_proof import simulate_additions
from hil.diagnosis.orders import spectrum_from_capture
from hil.sim import DriveConfig

DEAD_TIMES_S = (0.0, 0.5e-6, 1e-6, 1.5e-6, 2e-6, 3e-6, 4e-6)
POINTS = ((1000.0, 20.0), (1000.0, 10.0), (400.0, 20.0), (-1000.0, 20.0))


def main() -> None:
    config = DriveConfig()
    p = config.motor.parameters.pole_pairs
    for speed_rpm, current_a in POINTS:
        runs = [(speed_rpm, current_a, "addition_dead_time_s", t) if t else
                (speed_rpm, current_a, None, 0.0) for t in DEAD_TIMES_S]
        pairs = simulate_additions(config, runs, revolutions_elec=8, sample_rate_hz=25_000.0,
                                   seed=2)
        print(f"{speed_rpm:+g} rpm, {current_a:g} A")
        for t, (capture, op) in zip(DEAD_TIMES_S, pairs):
            c = spectrum_from_capture(capture, current_a=current_a,
                                      max_mech_order=12 * p + 2).coefficients_nm
            per_us = f"{abs(c[6 * p]) * 1e3 / (t * 1e6):6.3f} mN·m/µs" if t else " " * 13
            print(f"  {t * 1e6:4.1f} µs  order 6: {abs(c[6 * p]) * 1e3:7.3f} mN·m "
                  f"∠{np.degrees(np.angle(c[6 * p])):7.1f}° ({per_us})   order 12: "
                  f"{abs(c[12 * p]) * 1e3:7.3f} mN·m ∠{np.degrees(np.angle(c[12 * p])):7.1f}°")


if __name__ == "__main__":
    main()
