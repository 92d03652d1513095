"""A small stand-in with the ``hil.sim.DriveTwin`` interface, for unit tests of the DAQ and
transducer simulators while (or where) the real twin is not needed.

Physics-lite on purpose: the dyno holds speed, the phase currents follow the current command at
the electrical angle, a phase-a sensor offset injected into the drive leaves the opposite dc
current in the real phase current (the controller regulates the sensed one), and the torque is
computed from the real currents with the Table I torque constant (so the dc current gives an
order-1 torque term). Integration tests use the real twin when it exists (``twin_factory``).
"""

from __future__ import annotations

import importlib.util
import math
import threading
from dataclasses import dataclass, replace

import numpy as np

from hil.motor import TABLE_I


SPEED_RPM = 1000.0
CURRENT_A = 10.0


def make_twin(seed: int = 0):
    """The real ``hil.sim.DriveTwin`` once it exists, else the fake; at 1000 rpm, 10 A, enabled."""
    if importlib.util.find_spec("hil.sim.twin") is not None:
        from hil.sim import DriveTwin
        twin = DriveTwin(seed=seed)
    else:
        twin = FakeTwin(seed=seed)
    with twin.lock:
        twin.speed_rpm = SPEED_RPM
        twin.current_command_a = CURRENT_A
        twin.enable()
    return twin


@dataclass(frozen=True)
class FakeInjection:
    ia_offset_a: float = 0.0
    ib_offset_a: float = 0.0


class FakeTwin:
    """Interface-compatible fake of DriveTwin (simulated time; never sleeps)."""

    encoder_counts_per_rev = 7200

    def __init__(self, config=None, *, seed: int = 0) -> None:
        self.lock = threading.RLock()
        self.time_s = 0.0
        self.injection = FakeInjection()
        self.enabled = False
        self.current_command_a = 0.0
        self._speed_rpm = 0.0
        self._angle_mech_rad = 0.0
        self._rng = np.random.default_rng(seed)
        self.advance_calls = 0

    @property
    def speed_rpm(self) -> float:
        return self._speed_rpm

    @speed_rpm.setter
    def speed_rpm(self, value: float) -> None:
        if not -3000.0 <= value <= 3000.0:
            raise ValueError(f"speed_rpm={value} outside -3000..3000 rpm")
        self._speed_rpm = float(value)

    def set_injection(self, **values) -> None:
        with self.lock:
            self.injection = replace(self.injection, **values)

    def restore_defaults(self) -> None:
        with self.lock:
            self.injection = FakeInjection()

    def enable(self) -> None:
        self.enabled = True

    def disable(self) -> None:
        self.enabled = False

    def advance(self, duration_s: float, sample_rate_hz: float) -> dict[str, np.ndarray]:
        with self.lock:
            self.advance_calls += 1
            n = max(1, int(round(duration_s * sample_rate_hz)))
            t = self.time_s + np.arange(1, n + 1) / sample_rate_hz
            omega_m = self._speed_rpm * 2.0 * math.pi / 60.0
            angle = self._angle_mech_rad + omega_m * (t - self.time_s)
            theta_e = TABLE_I.pole_pairs * angle
            amp = self.current_command_a if self.enabled else 0.0
            ia = amp * np.cos(theta_e) - (self.injection.ia_offset_a if self.enabled else 0.0)
            ib = amp * np.cos(theta_e - 2 * math.pi / 3) - (
                self.injection.ib_offset_a if self.enabled else 0.0)
            ic = -ia - ib
            # torque from real currents: T = Kt_phase * sum(i_x * e_x), e_x unit EMF shapes
            kt = TABLE_I.torque_constant_nm_per_a / 1.5
            torque_em = kt * (ia * np.cos(theta_e) + ib * np.cos(theta_e - 2 * math.pi / 3)
                              + ic * np.cos(theta_e + 2 * math.pi / 3))
            torque = torque_em + 1e-4 * self._rng.standard_normal(n)
            counts = np.floor(angle / (2 * math.pi) * self.encoder_counts_per_rev).astype(
                np.int64)
            self.time_s = float(t[-1])
            self._angle_mech_rad = float(angle[-1])
            self._last = {"torque_nm": float(torque[-1]), "torque_em_nm": float(torque_em[-1]),
                          "ia_a": float(ia[-1]), "ib_a": float(ib[-1]),
                          "position_counts": int(counts[-1])}
            return {"time_s": t, "rotor_angle_mech_rad": angle, "encoder_counts": counts,
                    "ia_a": ia, "ib_a": ib, "ic_a": ic, "torque_nm": torque,
                    "torque_em_nm": torque_em, "dc_bus_v": np.full(n, TABLE_I.dc_bus_v),
                    "speed_rpm": np.full(n, self._speed_rpm), "id_a": np.zeros(n),
                    "iq_a": np.full(n, amp)}

    def status(self) -> dict:
        with self.lock:
            last = getattr(self, "_last", {"torque_nm": 0.0, "torque_em_nm": 0.0, "ia_a": 0.0,
                                           "ib_a": 0.0, "position_counts": 0})
            return dict(last, speed_rpm=self._speed_rpm, dc_bus_v=TABLE_I.dc_bus_v,
                        time_s=self.time_s)
