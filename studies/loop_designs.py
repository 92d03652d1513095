"""How much the twin's ripple moves with the current-loop design alone (issue 13 item 4).

For each loop variant (``hil.sim.FirmwareModel``) prints the torque ripple of a dead-time point
and of an encoder-at-speed point: pk-pk and the dominant order's amplitude over four electrical
revolutions sampled at the PWM valleys, per unit of the mean, and the ratio to the default loop.

    .venv/bin/python studies/loop_designs.py
"""

from __future__ import annotations

import numpy as np

from hil.sim import DriveConfig, FirmwareModel, Injection, simulate

REVS = 4
PWM_HZ = 20_000.0
VARIANTS = {
    "default (continuous, delay 1)": FirmwareModel(),
    "discrete": FirmwareModel(design="discrete"),
    "discrete + decoupling": FirmwareModel(design="discrete", decoupling=True),
    "EMF feed-forward": FirmwareModel(emf_feedforward=True),
    "delay 0": FirmwareModel(delay_periods=0.0),
    "delay 1.5": FirmwareModel(delay_periods=1.5),
    "delay 1.5 + angle comp.": FirmwareModel(delay_periods=1.5, angle_compensation=True),
    "all feed-forwards, comp.": FirmwareModel(decoupling=True, emf_feedforward=True,
                                              angle_compensation=True),
}
POINTS = {  # label: (speed rpm, current A, injection, order of interest)
    "dead time 2 µs, 500 rpm 20 A": (500.0, 20.0, Injection(dead_time_s=2e-6), 6),
    "encoder /50, 1000 rpm 20 A": (1000.0, 20.0, Injection(encoder_decimation=50), 72),
}


def ripple(firmware: FirmwareModel, speed_rpm, current_a, injection, order) -> tuple:
    config = DriveConfig(firmware=firmware, injection=injection, current_command_a=current_a,
                         speed_rpm=speed_rpm)
    duration = REVS / (2.0 * speed_rpm / 60.0)
    torque = simulate(config, duration, PWM_HZ, settle_s=0.05)["torque_em_nm"]
    spectrum = np.abs(np.fft.rfft(torque - torque.mean())) * 2.0 / len(torque)
    return np.ptp(torque) / torque.mean(), spectrum[order * REVS] / torque.mean()


def main() -> None:
    for label, (speed, current, injection, order) in POINTS.items():
        print(f"{label}: pk-pk and order {order}, % of the mean (ratio to the default)")
        base = None
        for name, firmware in VARIANTS.items():
            pk_pk, amplitude = ripple(firmware, speed, current, injection, order)
            base = base or (pk_pk, amplitude)
            print(f"  {name:<30} {pk_pk * 100:6.3f} ({pk_pk / base[0]:4.2f})   "
                  f"{amplitude * 100:6.3f} ({amplitude / base[1]:4.2f})")


if __name__ == "__main__":
    main()
