"""Study: why the PWM-switching analysis reads high at low speed and 40 kHz (hil/model/README.md,
"PWM switching"; issue 29's deviation study, Table I 250 rpm / 5 A).

Run: ``.venv/bin/python studies/switching_window_wander.py`` (≈ 1 min on one core).

The twin at Table I 250 rpm / 5 A, captured at the rate the plan's ``capture_settings`` gives
(≤ 200 kS/s), analysed by ``hil.analysis.switching.analyze_switching`` — the plan's own chain —
and divided by the switched-torque model. Rows vary one thing at a time: the PWM frequency, the
drive's current-ADC resolution (12 bits as shipped, 20 bits: no quantisation to speak of), the
loop's bandwidth per PWM frequency, and the analysis window (its largest electrical angle,
``MAX_WINDOW_ANGLE_RAD``: 3° as shipped). The measured figures come from the twin through
hil.analysis only; the prediction is used for the ratio and nothing else.
"""

from __future__ import annotations

import math

import numpy as np

from hil.analysis import switching
from hil.capture import Capture
from hil.errors import InputError
from hil.model import OperatingPoint, predict
from hil.motor import MotorParameters
from hil.sim import DriveConfig, simulate
from hil.sim.config import FirmwareModel, SensorModel
from hil.sim.injection import Injection

SPEED_RPM, CURRENT_A = 250.0, 5.0
MAX_RATE_HZ, BUFFER = 200_000.0, 200_000
CHANNELS = ("ia_a", "ib_a", "rotor_angle_mech_rad")


def ratio(pwm_hz: float, adc_bits: int = 12, bandwidth_per_pwm: float = 0.08,
          window_deg: float = 3.0) -> tuple[float, float, int]:
    """(measured/model, U/model, G) at one setting."""
    motor = MotorParameters()
    shipped = switching.MAX_WINDOW_ANGLE_RAD
    switching.MAX_WINDOW_ANGLE_RAD = math.radians(window_deg)
    switching.capture_settings.cache_clear()        # its rate depends on the window
    try:
        settings = switching.capture_settings(SPEED_RPM, motor.pole_pairs, pwm_hz,
                                              max_sample_rate_hz=MAX_RATE_HZ,
                                              buffer_samples=BUFFER, max_order=24)
        elec_hz = SPEED_RPM * motor.pole_pairs / 60.0
        config = DriveConfig(current_command_a=CURRENT_A, speed_rpm=SPEED_RPM,
                             sensors=SensorModel(adc_bits=adc_bits),
                             firmware=FirmwareModel(bandwidth_per_pwm=bandwidth_per_pwm),
                             injection=Injection(pwm_frequency_hz=pwm_hz))
        run = simulate(config, (settings.revolutions + 0.25) / elec_hz,
                       settings.sample_rate_hz, settle_s=0.05, channels=CHANNELS)
        channels = {name: run.channels[name] for name in CHANNELS}
        # the DAQ's time stamps: its sample clock's ticks (drivers/simulated/modbus_daq_server)
        channels["time_s"] = np.arange(channels["ia_a"].size) / settings.sample_rate_hz
        result = switching.analyze_switching(Capture(channels, meta={"pole_pairs": 2}),
                                             pwm_frequency_hz=pwm_hz, motor=motor, max_order=24)
        periods = switching.window_periods(2 * math.pi * elec_hz, pwm_hz)
    finally:
        switching.MAX_WINDOW_ANGLE_RAD = shipped
        switching.capture_settings.cache_clear()
    model = predict("pwm_switching", OperatingPoint(speed_rpm=SPEED_RPM, current_a=CURRENT_A),
                    pwm_frequency_hz=pwm_hz, model="switched_torque", modulation="svpwm")
    return (result.pk_pk_pu / model.pk_pk_pu, result.uncertainty.expanded_pu / model.pk_pk_pu,
            periods)


ROWS = [("PWM 10 kHz", dict(pwm_hz=10_000.0)),
        ("PWM 20 kHz", dict(pwm_hz=20_000.0)),
        ("PWM 40 kHz", dict(pwm_hz=40_000.0)),
        ("PWM 40 kHz, 20-bit ADC", dict(pwm_hz=40_000.0, adc_bits=20)),
        ("PWM 40 kHz, loop 0.04·f_pwm", dict(pwm_hz=40_000.0, bandwidth_per_pwm=0.04)),
        ("PWM 40 kHz, loop 0.10·f_pwm", dict(pwm_hz=40_000.0, bandwidth_per_pwm=0.10))]
ROWS += [(f"PWM 40 kHz, {bits}-bit ADC, {deg:g}° windows",
          dict(pwm_hz=40_000.0, adc_bits=bits, window_deg=deg))
         for deg in (1.5, 1.0, 0.5) for bits in (12, 20)]


def main() -> None:
    print("| setting | G | measured / model | U / model |\n|---|---|---|---|")
    for label, kwargs in ROWS:
        try:
            value, u, periods = ratio(**kwargs)
        except InputError as exc:
            print(f"| {label} | | refused: {exc} | |", flush=True)
            continue
        print(f"| {label} | {periods} | {value:.3f} | {u:.3f} |", flush=True)


if __name__ == "__main__":
    main()
