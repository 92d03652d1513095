"""``DriveTwin``: the stateful simulated drive + dyno that the simulated instruments share.

Simulated time only: ``advance`` runs the engine forward and never sleeps. Each call continues
from the electrical, firmware and mechanical state the previous one left, so consecutive captures
join up; injections and commands changed between calls take effect from the PWM period in which
the next call starts. Thread-safe: every public method holds ``lock``.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Iterable
from dataclasses import replace

import numpy as np

from hil.sim import layout as L
from hil.sim.config import DriveConfig, check_current_command, check_speed
from hil.sim.defects import DriveDefects
from hil.sim.engine import sample_count
from hil.sim.injection import Injection
from hil.sim.kernel import run_drive
from hil.sim.packing import new_state, pack_params
from hil.sim.results import (NO_LATEST, NO_ROWS, NO_SAMPLES, name_channels, select_channels,
                             transducer_gain_error)


class DriveTwin:
    """Simulated drive under test on a speed-holding dyno (see COMMON.md for the contract).

    ``defects`` (test-only, ``hil.sim.defects``): the drive reads back the commanded injection
    (``injection``) but simulates ``defects.applied_config(config)`` (the applied injection, a
    slower transducer or current loop than stated); the transducer reading
    ``torque_nm`` (which the DAQ and the serial transducer both serve) is scaled by
    ``defects.transducer_scale``.
    """

    def __init__(self, config: DriveConfig | None = None, *, seed: int = 0,
                 defects: DriveDefects | None = None) -> None:
        self.lock = threading.RLock()
        self._config = config if config is not None else DriveConfig()
        self.defects = defects if defects is not None else DriveDefects()
        self._state = new_state()
        self._rng = np.random.default_rng(seed)
        self._gain_error_pu = transducer_gain_error(self._config, self._rng)
        self.time_s = 0.0
        self._latest: dict[str, float] = {}

    # ---- configuration --------------------------------------------------------------------
    @property
    def config(self) -> DriveConfig:
        with self.lock:
            return self._config

    @property
    def injection(self) -> Injection:
        with self.lock:
            return self._config.injection

    def set_injection(self, **values) -> None:
        """Change injection knobs; ValueError (field and allowed range) leaves them unchanged."""
        with self.lock:
            injection = self._config.injection.with_values(**values)
            self._config = replace(self._config, injection=injection)

    def restore_defaults(self) -> None:
        with self.lock:
            self._config = replace(self._config, injection=Injection())

    @property
    def enabled(self) -> bool:
        with self.lock:
            return self._config.enabled

    def enable(self) -> None:
        with self.lock:
            self._config = replace(self._config, enabled=True)

    def disable(self) -> None:
        """Gates off: no current (the firmware's integrators reset)."""
        with self.lock:
            self._config = replace(self._config, enabled=False)

    @property
    def current_command_a(self) -> float:
        with self.lock:
            return self._config.current_command_a

    @current_command_a.setter
    def current_command_a(self, value: float) -> None:
        with self.lock:
            self._config = replace(self._config, current_command_a=check_current_command(value))

    @property
    def speed_rpm(self) -> float:
        """The dyno speed setpoint, rpm."""
        with self.lock:
            return self._config.speed_rpm

    @speed_rpm.setter
    def speed_rpm(self, value: float) -> None:
        with self.lock:
            self._config = replace(self._config, speed_rpm=check_speed(value))

    # ---- simulation -----------------------------------------------------------------------
    def advance(self, duration_s: float, sample_rate_hz: float, *, settle_s: float = 0.0,
                channels: Iterable[str] | None = None) -> dict[str, np.ndarray]:
        """Run ``settle_s`` unrecorded, then ``duration_s`` sampled at ``sample_rate_hz``.

        Returns the standard channels (``time_s`` in simulated seconds since construction), or
        only those named in ``channels`` (``hil.sim.results.STANDARD_CHANNELS``; unknown names
        are a ValueError): the others are not computed, the drive's state evolves the same.
        The transducer noise is drawn only when ``torque_nm`` is asked for.
        """
        with self.lock:
            if not settle_s >= 0:
                raise ValueError(f"settle_s must be >= 0, got {settle_s!r}")
            n = sample_count(duration_s, sample_rate_hz)
            names, rows = select_channels(channels)
            simulated = self._config
            if self.defects.active:
                simulated = self.defects.applied_config(simulated)
            params = pack_params(simulated)
            dt = 1.0 / sample_rate_hz
            if settle_s > 0:
                self._state = run_drive(params, self._state.copy(), self.time_s + settle_s, dt,
                                        NO_SAMPLES, NO_ROWS, NO_LATEST, self.time_s + settle_s)
                self.time_s += settle_s
            out = np.zeros((int((rows >= 0).sum()), n))
            latest = np.zeros(L.N_CHANNELS)
            self._state = run_drive(params, self._state.copy(), self.time_s, dt, out, rows,
                                    latest, self.time_s + duration_s)
            self.time_s += duration_s
            channels = name_channels(out, rows, names, self._config, self._gain_error_pu,
                                     self._rng)
            if "torque_nm" in channels and self.defects.transducer_scale != 1.0:
                channels["torque_nm"] *= self.defects.transducer_scale
            if n:
                self._remember_latest(latest, channels)
            return channels

    def next_carrier_valley_s(self) -> float:
        """Simulated time (s) of the first PWM counter valley (period start) at or after
        ``time_s``, at the PWM frequency the drive runs now.

        The engine keeps the start of the period containing ``time_s`` (``run_drive`` returns
        it and the next call re-runs that period, at the frequency then in force), so the
        valleys ahead are that start + k/f_pwm.
        """
        with self.lock:
            start_s = float(self._state[L.S_TIME])
            period_s = 1.0 / self._config.injection.pwm_frequency_hz
            if self._state[L.S_INITIALISED] == 0.0 or start_s >= self.time_s:
                return max(start_s, self.time_s)
            periods = math.ceil((self.time_s - start_s) / period_s - 1e-9)
            return start_s + periods * period_s

    def advance_to_carrier_valley(self) -> float:
        """Run unrecorded up to ``next_carrier_valley_s()`` (less than one PWM period) and
        return the time offset this added (s).

        A DAQ whose sample clock is synchronised to the drive's PWM carrier (first sample at a
        counter valley) captures through this: the phase of its samples within the PWM period,
        and so what a sample rate commensurate with f_pwm aliases of the switching ripple, no
        longer depends on how much simulated time the bench has run (issue 22.1).
        """
        with self.lock:
            valley_s = self.next_carrier_valley_s()
            gap_s = valley_s - self.time_s
            if gap_s > 0.0:
                self.advance(gap_s, 0.5 / gap_s, channels=())   # no sample
            self.time_s = valley_s
            return gap_s

    def _remember_latest(self, latest: np.ndarray, channels: dict[str, np.ndarray]) -> None:
        """``status()``'s scalars from the engine's every-channel values at the last sample
        (``run_drive``'s ``latest``, the same numbers as the recorded channels; where a channel
        was not asked for, the exact solution evaluated directly at that instant). The
        transducer reading is the recorded ``torque_nm`` (with its noise) when it was asked
        for, else the noise-free reading (front end × (1 + gain error) × defect scale)."""
        if "torque_nm" in channels:
            torque_nm = float(channels["torque_nm"][-1])
        else:
            torque_nm = float(latest[L.C_TORQUE_SHAFT_FILTERED] * (1.0 + self._gain_error_pu)
                              * self.defects.transducer_scale)
        self._latest = {"torque_nm": torque_nm,
                        "torque_em_nm": float(latest[L.C_TORQUE_EM]),
                        "speed_rpm": float(latest[L.C_SPEED_RPM]),
                        "ia_a": float(latest[L.C_IA]), "ib_a": float(latest[L.C_IB]),
                        "dc_bus_v": self._config.motor.parameters.dc_bus_v,
                        "position_counts": int(latest[L.C_COUNTS])}

    def status(self) -> dict:
        """Latest scalars: from the last sample taken, else from the engine state."""
        with self.lock:
            state = self._state
            cpr = self._config.sensors.encoder_counts_per_rev
            speed = state[L.S_OMEGA_M] * 60 / (2 * math.pi) if state[L.S_INITIALISED] \
                else self._config.speed_rpm
            latest = {
                "torque_nm": 0.0, "torque_em_nm": 0.0, "speed_rpm": float(speed),
                "position_counts": int(math.floor(state[L.S_THETA_M] * cpr / (2 * math.pi))),
                "ia_a": float(state[L.S_IA]), "ib_a": float(state[L.S_IB]),
                "dc_bus_v": self._config.motor.parameters.dc_bus_v,
            }
            latest.update(self._latest)
            latest["time_s"] = self.time_s
            return latest
