"""Small helpers shared by the CANopen driver tests."""

from __future__ import annotations

import time

from ripple_hil_drivers.errors import HeartbeatLost

# A non-default value for every knob, each exactly representable in the EDS encoding.
NON_DEFAULT = {
    "ia_offset_a": 0.25, "ib_offset_a": -1.5, "ia_gain_error_pu": 0.02, "ib_gain_error_pu": -0.05,
    "encoder_decimation": 100, "hall_mode": True, "word_length_bits": 12,
    "pwm_period_counts": 500, "pwm_frequency_hz": 10000, "dead_time_s": 2.5e-6,
    "current_angle_rad": 0.5, "loop_test_amplitude_a": 2.0, "loop_test_order": 48,
}


#: Scheduling slack allowed on a loaded machine between a loss and the poll that sees it, s.
POLL_SLACK_S = 0.05


def eventually(predicate, timeout_s: float = 2.0) -> bool:
    """True as soon as ``predicate()`` is, False if it is not within ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    while not predicate():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.005)
    return True


def poll_until_heartbeat_lost(drive, clock=time.monotonic, poll_s: float = 0.002):
    """Call ``drive.check_health()`` every ``poll_s`` until HeartbeatLost: (clock time, message)."""
    while True:
        try:
            drive.check_health()
        except HeartbeatLost as exc:
            return clock(), str(exc)
        time.sleep(poll_s)
