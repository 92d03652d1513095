"""A small stand-in with the ``hil.sim.DriveTwin`` interface (COMMON.md), for tests only.

Used until ``hil.sim.DriveTwin`` exists; ``conftest.twin_factory`` prefers the real one.
It validates knobs with the COMMON.md ranges and keeps simple scalar state (no physics).
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass, fields, replace

RANGES = {
    "ia_offset_a": (-20.0, 20.0), "ib_offset_a": (-20.0, 20.0),
    "ia_gain_error_pu": (-0.2, 0.2), "ib_gain_error_pu": (-0.2, 0.2),
    "encoder_decimation": (1, 1800), "hall_mode": (False, True),
    "word_length_bits": (0, 32), "pwm_period_counts": (8, 65535),
    "pwm_frequency_hz": (2000.0, 50000.0), "dead_time_s": (0.0, 10e-6),
    "current_angle_rad": (-math.pi / 2, math.pi / 2),
}


@dataclass(frozen=True)
class FakeInjection:
    ia_offset_a: float = 0.0
    ib_offset_a: float = 0.0
    ia_gain_error_pu: float = 0.0
    ib_gain_error_pu: float = 0.0
    encoder_decimation: int = 1
    hall_mode: bool = False
    word_length_bits: int = 0
    pwm_period_counts: int = 2000
    pwm_frequency_hz: float = 20000.0
    dead_time_s: float = 0.0
    current_angle_rad: float = 0.0

    def validate(self) -> None:
        for f in fields(self):
            low, high = RANGES[f.name]
            value = getattr(self, f.name)
            if not low <= value <= high:
                raise ValueError(f"{f.name}={value!r} is outside {low}..{high}")
        if 0 < self.word_length_bits < 6:
            raise ValueError(f"word_length_bits={self.word_length_bits} must be 0 or 6..32")


class FakeTwin:
    def __init__(self, config=None, *, seed: int = 0) -> None:
        self.lock = threading.RLock()
        self.time_s = 0.0
        self.injection = FakeInjection()
        self.enabled = False
        self._current_command_a = 0.0
        self._speed_rpm = 0.0
        self.position_counts = 0

    def set_injection(self, **values) -> None:
        with self.lock:
            unknown = set(values) - set(RANGES)
            if unknown:
                raise ValueError(f"unknown injection fields {sorted(unknown)}")
            candidate = replace(self.injection, **values)
            candidate.validate()
            self.injection = candidate

    def restore_defaults(self) -> None:
        with self.lock:
            self.injection = FakeInjection()

    def enable(self) -> None:
        with self.lock:
            self.enabled = True

    def disable(self) -> None:
        with self.lock:
            self.enabled = False

    @property
    def current_command_a(self) -> float:
        return self._current_command_a

    @current_command_a.setter
    def current_command_a(self, value: float) -> None:
        if not 0.0 <= value <= 100.0:
            raise ValueError(f"current_command_a={value!r} is outside 0..100 A")
        self._current_command_a = float(value)

    @property
    def speed_rpm(self) -> float:
        return self._speed_rpm

    @speed_rpm.setter
    def speed_rpm(self, value: float) -> None:
        if not -3000.0 <= value <= 3000.0:
            raise ValueError(f"speed_rpm={value!r} is outside -3000..3000 rpm")
        self._speed_rpm = float(value)

    def advance(self, duration_s: float, sample_rate_hz: float) -> dict:
        with self.lock:
            self.time_s += duration_s
            self.position_counts += int(round(self._speed_rpm / 60.0 * duration_s * 7200))
            return {}

    def status(self) -> dict:
        with self.lock:
            torque = 0.0488 * self._current_command_a if self.enabled else 0.0
            return {"torque_nm": torque, "torque_em_nm": torque, "speed_rpm": self._speed_rpm,
                    "position_counts": self.position_counts, "ia_a": 0.0, "ib_a": 0.0,
                    "dc_bus_v": 12.0, "time_s": self.time_s}
