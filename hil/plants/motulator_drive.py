"""motulator's objects for :class:`hil.plants.motulator_plant.MotulatorPlant`, kept alive across
captures: one ``Drive`` model (machine, dyno, inverter) whose state carries on, and its
control system, rebuilt when its sampling period, its loop or the gate release asks for it.

Imports motulator (``.venv-motulator``); only the plant imports this module. The history of
every run is taken and then cleared from motulator's buffers (``Model._history``,
``ControlSystem.clear_data``), so a long-lived bench neither grows nor slows: this relies on
motulator 0.18's model history (``.ci/setup-motulator`` pins that version).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from motulator.common.model._base import ModelStateHistory
from motulator.common.utils import complex2abc
from motulator.drive import model
import motulator.drive.control.sm as control


#: While the gates are blocked nothing is modulated: the controller then samples at this rate
#: (Hz; T_s = 125 us, motulator's default sampling period), which saves motulator its
#: carrier-rate steps; the diode model still locates every conduction interval as an event.
#: At 1 kHz (0.5 ms solver intervals) its diode events were missed: 0.4 A flowed at 1500 rpm
#: with the line EMF (8.9 V) below the bus (12 V) — tests/independent/test_foreign_bench.py
#: checks there is none.
STANDBY_CARRIER_HZ = 4000.0


class TwoPhaseSensors:
    """motulator ``Sensor`` on phases a and b (gain 1 + g, offset Δ); phase c = −a − b."""

    def __init__(self) -> None:
        from motulator.common.model import Sensor

        self.sensor = Sensor(gain=[1.0, 1.0], offset=[0.0, 0.0])

    def set(self, gains_pu, offsets_a) -> None:
        self.sensor.gain = [1.0 + gains_pu[0], 1.0 + gains_pu[1]]
        self.sensor.offset = list(offsets_a)

    def __call__(self, i_abc):
        a, b = self.sensor(np.asarray(i_abc)[:2])
        return np.array([a, b, -a - b])


class EncoderShaft(model.ExternalRotorSpeed):
    """motulator's speed-holding dyno whose measured angle (what the controller reads) is the
    encoder's: ``counts_per_rev`` counts per mechanical revolution, read every
    ``decimation``-th count (θ_read = ⌊θ·N/(2π·d)⌋·2π·d/N, N/d need not be an integer)."""

    counts_per_rev = 7200
    decimation = 1

    def meas_position(self) -> float:
        theta = super().meas_position()
        step = 2 * math.pi * self.decimation / self.counts_per_rev
        return math.floor(theta / step) * step


class FixedCurrentReference:
    """A current-commanded drive's reference (motulator's ``ReferenceGenerator`` interface):
    the current lagging the EMF by φ (the contract's ``current_angle_rad``, paper eq 4) in
    motulator's frame, whose d axis is the magnet's and whose EMF jω·ψ_f lies on +q:
    i_d + j·i_q = I·(sin φ + j·cos φ) = I·j·e^(−jφ), whatever the torque reference; zero while
    the gates are blocked. (The twin writes −I·sin φ on its own d axis, which points the other
    way: the self-check measures motulator's angle reference at 180°. Until 2026-12-07 this
    adapter wrote −I·sin φ too, a current *leading* by φ, and the encoder plan's count order at
    φ = 10° read 0.61 of the model: cos(φ − γ) instead of eq 7's cos(γ + φ).)"""

    def __init__(self, par) -> None:
        self.par = par
        self.i_s_ref = 0j

    def set(self, current_a: float, angle_rad: float) -> None:
        self.i_s_ref = current_a * complex(math.sin(angle_rad), math.cos(angle_rad))

    def compute_flux_and_torque_refs(self, tau_M_ref, w_m, u_dc):
        psi = complex(self.par.psi_s_dq(self.i_s_ref))
        return abs(psi), 1.5 * self.par.n_p * (psi.conjugate() * self.i_s_ref).imag

    def compute_current_ref(self, tau_M_ref):
        return self.i_s_ref

    def update(self, T_s):
        pass


@dataclass
class History:
    """One run's solution in plant time (sorted): currents, torque, angle, voltages."""

    t: np.ndarray
    tau: np.ndarray
    angle: np.ndarray
    ia_a: np.ndarray
    ib_a: np.ndarray
    ic_a: np.ndarray
    id_a: np.ndarray
    iq_a: np.ndarray
    ia_sensed_a: np.ndarray
    ib_sensed_a: np.ndarray
    v_abc: np.ndarray
    pwm_period_s: float
    t_end: float
    angle_end_rad: float
    torque_nm: np.ndarray | None = None

    @property
    def torque_em_nm(self) -> np.ndarray:
        return self.tau

    @property
    def torque_shaft_nm(self) -> np.ndarray:
        return self.tau       # the dyno holds the speed: no inertia between gap and shaft

    def period_average(self, t: np.ndarray, name: str) -> np.ndarray:
        """Phase voltage ``name`` averaged over the PWM period centred on each instant (the
        converter's voltage is constant between solver points)."""
        v = self.v_abc["abc".index(name[1])]
        # trapezoids: exact for a voltage constant between switching instants (both ends of an
        # interval carry its state) and for the smooth back EMF of blocked gates
        cum = np.concatenate(([0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(self.t))))
        lo = np.clip(t - 0.5 * self.pwm_period_s, self.t[0], self.t[-1])
        hi = np.clip(t + 0.5 * self.pwm_period_s, self.t[0], self.t[-1])
        width = np.maximum(hi - lo, 1e-12)
        return (np.interp(hi, self.t, cum) - np.interp(lo, self.t, cum)) / width


class MotulatorDrive:
    """One motulator ``Drive`` and its control system, continued run after run."""

    def __init__(self, motor, t0_s: float) -> None:
        L = motor.phase_inductance_h
        self.par = model.SynchronousMachinePars(n_p=motor.pole_pairs,
                                                R_s=motor.phase_resistance_ohm, L_d=L, L_q=L,
                                                psi_f=motor.flux_linkage_wb)
        self.u_dc = float(motor.dc_bus_v)
        self.sensors = TwoPhaseSensors()
        self.machine = model.SynchronousMachine(self.par, i_s_sensor=self.sensors)
        self.shaft = EncoderShaft()
        self.converter = model.VoltageSourceConverter(u_dc=self.u_dc, t_d=0.0)
        self.mdl = model.Drive(self.machine, self.shaft, self.converter, pwm=True)
        self.offset_s = float(t0_s)          # plant time − motulator time
        self.angle_rad = 0.0                 # unwrapped mechanical angle at the model's t0
        self.ctrl = None
        self.sim = None
        self.reference = FixedCurrentReference(self.par)
        self._key = None
        self._enabled = False

    def configure(self, applied, *, enabled: bool, current_a: float, speed_rpm: float,
                  bandwidth_hz: float, design: str, encoder_counts_per_rev: int) -> None:
        """Put the commands and the applied injection in place before the next run."""
        self.sensors.set((applied.ia_gain_error_pu, applied.ib_gain_error_pu),
                         (applied.ia_offset_a, applied.ib_offset_a))
        # motulator's carrier comparison (``Model.pwm``, made from the converter's t_d when the
        # model was built) blanks each leg t_d and rounds the duty to 1/N: both set here
        self.converter.t_d = float(applied.dead_time_s)
        self.mdl.pwm.t_d = float(applied.dead_time_s)
        self.mdl.pwm.N = int(applied.pwm_period_counts)
        self.shaft.set_external_rotor_speed(speed_rpm * 2 * math.pi / 60.0)
        self.shaft.counts_per_rev = int(encoder_counts_per_rev)
        self.shaft.decimation = int(applied.encoder_decimation)
        pwm_hz = float(applied.pwm_frequency_hz) if enabled else STANDBY_CARRIER_HZ
        key = (pwm_hz, float(bandwidth_hz), design, max(2.0 * current_a, 1.0))
        if self.ctrl is None or key != self._key or (enabled and not self._enabled):
            self._build_control(*key)
            self._key = key
        self.reference.set(current_a if enabled else 0.0, applied.current_angle_rad)
        self.ctrl.set_enable(bool(enabled))
        self._enabled = bool(enabled)

    def _build_control(self, pwm_hz: float, bandwidth_hz: float, design: str,
                       i_max_a: float) -> None:
        cfg = control.CurrentVectorControllerCfg(
            i_s_max=i_max_a, alpha_c=2 * math.pi * bandwidth_hz, sensorless=False,
            T_s=0.5 / pwm_hz, discrete=design == "discrete")
        vector = control.CurrentVectorController(self.par, cfg)
        vector.reference_gen = self.reference
        self.ctrl = control.VectorControlSystem(vector)
        self.ctrl.set_torque_ref(0.0)            # unused by the fixed current reference
        self.sim = model.Simulation(self.mdl, self.ctrl, show_progress=False)
        self.pwm_period_s = 1.0 / pwm_hz

    def run(self, t_plant_s: float, duration_s: float) -> History:
        """Simulate from the model's present time to at least ``t_plant_s + duration_s``."""
        self._clear()
        res = self.sim.simulate(t_stop=t_plant_s + duration_s - self.offset_s, N_eval=0)
        if not res.success:
            raise RuntimeError(f"motulator stopped at {self.mdl.t0:.6f} s (numerical failure)")
        t = np.asarray(res.mdl.t, dtype=float)
        order = np.argsort(t, kind="stable")
        t = t[order] + self.offset_s
        machine = res.mdl.machine
        i_abc = np.real(complex2abc(np.asarray(machine.i_s_ab)[order]))
        i_dq = np.asarray(machine.i_s_dq)[order]
        theta = np.unwrap(np.asarray(res.mdl.mechanics.theta_M, dtype=float)[order])
        angle = theta - theta[0] + self.angle_rad
        sensed = self.sensors.sensor(i_abc[:2].T).T   # (1 + g)·i + Δ of sensors a and b
        v_abc = np.real(complex2abc(np.asarray(res.mdl.converter.u_c_ab)[order])) \
            + 0.5 * self.u_dc                  # referred to the dc bus midpoint (only differences count)
        t_end = float(self.mdl.t0) + self.offset_s
        w = self.shaft.meas_speed()
        angle_end = angle[-1] + w * (t_end - t[-1])
        self.angle_rad = angle_end
        return History(t=t, tau=np.asarray(machine.tau_M, dtype=float)[order], angle=angle,
                       ia_a=i_abc[0], ib_a=i_abc[1], ic_a=i_abc[2], id_a=i_dq.real,
                       iq_a=i_dq.imag, ia_sensed_a=sensed[0], ib_sensed_a=sensed[1],
                       v_abc=v_abc, pwm_period_s=self.pwm_period_s, t_end=t_end,
                       angle_end_rad=angle_end)

    def _clear(self) -> None:
        """Drop motulator's stored history (the last run's was taken already)."""
        self.mdl._history = ModelStateHistory()
        for subsystem in self.mdl.subsystems:
            subsystem.init_state_history()
        self.ctrl.clear_data()
