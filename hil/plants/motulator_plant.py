"""A drive nobody here wrote behind the simulated instruments: motulator's PMSM, inverter and
current controller (``[simulation] plant = "motulator"``; motulator 0.18 in ``.venv-motulator``,
``.ci/setup-motulator``).

What is motulator's (its published package, driven through its API):

* machine ``SynchronousMachine`` (R, L_d = L_q = the bench file's L, ψ_f from its Ke); the dyno
  ``ExternalRotorSpeed`` (speed held exactly); inverter ``VoltageSourceConverter(u_dc, t_d)``
  with its carrier comparison (``Drive(pwm=True)``, ``CarrierComparison(N, t_d)``): the duty
  rounded to its counter's 1/N (N = ``pwm_period_counts``), switching instants and the dead
  time's blanking intervals resolved, the leg voltage during blanking set by the current's
  sign; gates blocked (drive disabled) with its diode model;
* controller ``CurrentVectorController`` (sensored) with its continuous-time 2-DOF
  complex-vector PI (the bench file's ``current_loop_design = "2dof"``, ``hil.current_loop``;
  a file stating "continuous" misstates this drive, which runs the 2-DOF design all the same)
  or, ``[drive] current_loop_design = "discrete"``, its direct discrete-time design (not the
  twin's pole-matched PI), α_c = 2π·``current_loop_bandwidth_hz``, sampling twice per carrier
  period with one sample of computational delay, its SVPWM (``PWM``, min/max zero sequence),
  gate enable (``set_enable``);
* current sensors ``Sensor`` (gain and offset per phase).

What this module adds, each a thing motulator leaves to its user:

* the reference: a current-commanded drive (i_d = −I·sin φ, i_q = I·cos φ, paper eq 4) instead
  of motulator's torque-to-current generator;
* two current sensors (a, b) with phase c computed as −a − b (the paper's two-sensor drive);
* the encoder: the angle the controller reads (``meas_position``) quantised to
  ``encoder_counts_per_rev / encoder_decimation`` counts per mechanical revolution;
* the bench around the drive: the transducer (first order at ``[torque] bandwidth_hz``, a gain
  error within its accuracy class drawn from the seed, white noise) on motulator's torque, the
  DAQ's encoder counter on motulator's rotor angle, the phase voltages from motulator's
  converter voltage.

Word length and Hall commutation are refused (``hil.plants.capabilities``): motulator computes in
floating point and reads an encoder. Nothing of ``hil.sim`` computes a sample here: the
injection object (``hil.sim.injection.Injection``) and the test-only defects' mapping from a
commanded to an applied injection (``hil.sim.defects.DriveDefects.applied``) are data.

Speed: tens of wall seconds per simulated second (carrier comparison at 20 kHz). motulator runs
in a worker process (``hil.plants.motulator_process``) and the simulated DAQ waits for it in its
capture thread, so the instruments keep answering (heartbeat, statusword, SDO, Modbus polls)
while motulator computes. The DAQ's first sample is not aligned to a carrier valley (the plant
has no ``advance_to_carrier_valley``): a free-running DAQ, as on a real bench.
"""

from __future__ import annotations

import contextlib
import math
import threading
from types import SimpleNamespace

import numpy as np

from hil.errors import InputError
from hil.plants.capabilities import UNSUPPORTED_KNOBS, defect_problems, knob_refusal
from hil.sim.defects import DriveDefects
from hil.sim.injection import Injection

#: ``[simulation.actual]`` keys a motulator bench honours: they belong to the simulated DAQ, not
#: to the plant (``hil.actual``).
PLANT_INDEPENDENT_ACTUAL = frozenset({"daq_voltage_gain"})

PLANT = "motulator"
#: How often a command that must stop the worker (disable, close) looks for a stretch to
#: abandon while it waits for ``MotulatorPlant.lock``, s.
LOCK_POLL_S = 0.05
#: the channels ``advance`` can return (the same names as the ripple-hil twin's)
CHANNELS = ("time_s", "rotor_angle_mech_rad", "encoder_counts", "ia_a", "ib_a", "ic_a",
            "torque_em_nm", "torque_shaft_nm", "speed_rpm", "id_a", "iq_a", "va_v", "vb_v",
            "vc_v", "ia_sensed_a", "ib_sensed_a", "torque_nm", "dc_bus_v")
#: the bench's transducer: white noise per output sample (N·m rms) and accuracy class (% of
#: reading, the gain error's bound) when the bench file states none
TRANSDUCER_NOISE_RMS_NM = 2e-4
TRANSDUCER_ACCURACY_PCT = 0.1
#: current limit handed to motulator's controller, × the commanded current (its reference
#: generator's i_s_max; the fixed reference never asks more than the command)
I_MAX_FACTOR = 2.0


def motulator_version() -> str:
    from importlib.metadata import version

    return version("motulator")


class MotulatorPlant:
    """``hil.plants.Plant`` backed by motulator (module docstring)."""

    def __init__(self, motor, *, bandwidth_hz: float = 1000.0, design: str = "continuous",
                 transducer_bandwidth_hz: float | None = 1000.0, encoder_counts_per_rev: int = 7200,
                 defects: DriveDefects | None = None, seed: int = 0) -> None:
        self.motor = motor
        self.bandwidth_hz = float(bandwidth_hz)
        self.design = design
        self.transducer_bandwidth_hz = transducer_bandwidth_hz
        self.defects = defects if defects is not None else DriveDefects()
        problems = defect_problems(PLANT, self.defects.to_dict())
        if problems:
            raise ValueError("; ".join(problems))
        self.lock = threading.RLock()
        self.config = SimpleNamespace(
            sensors=SimpleNamespace(encoder_counts_per_rev=int(encoder_counts_per_rev)),
            motor=SimpleNamespace(parameters=motor))
        self._rng = np.random.default_rng(seed)
        self._gain_error_pu = float(self._rng.uniform(-1.0, 1.0)) * TRANSDUCER_ACCURACY_PCT / 100
        self._injection = Injection()
        self._enabled = False
        self._current_command_a = 0.0
        self._speed_rpm = 0.0
        self.time_s = 0.0
        self._angle_mech_rad = 0.0       # unwrapped rotor angle at time_s
        self._filter_nm: float | None = None
        self._latest: dict = {}
        self._drive = None               # motulator objects, built on first use
        self._computing = None           # the worker while it computes a stretch (``_run``)

    @classmethod
    def from_bench(cls, bench, *, seed: int = 0) -> "MotulatorPlant":
        """The plant a simulated bench file describes: its ``[motor]``, its ``[drive]`` loop
        bandwidth and design, its ``[torque]`` bandwidth, its test-only defects. A
        ``[simulation.actual]`` physics other than the DAQ's own gain is refused: this plant runs
        the ``[motor]`` it is given, and would silently run the nameplate instead."""
        ignored = sorted(set(bench.sim_actual) - PLANT_INDEPENDENT_ACTUAL)
        if ignored:
            raise InputError(f"{bench.source}: [simulation.actual] {', '.join(ignored)} is the "
                             f"ripple-hil twin's physics; [simulation] plant = \"motulator\" "
                             f"runs the [motor] table as its motor (state it there)")
        drive = bench.drive
        return cls(bench.motor, bandwidth_hz=drive.current_loop_bandwidth_hz or 1000.0,
                   design=drive.current_loop_design,
                   transducer_bandwidth_hz=bench.torque.bandwidth_hz,
                   defects=DriveDefects.from_dict(bench.sim_defects), seed=seed)

    @property
    def identity(self) -> str:
        return (f"motulator {motulator_version()} (SynchronousMachine, VoltageSourceConverter "
                f"carrier comparison, CurrentVectorController {self.design} "
                f"{self.bandwidth_hz:g} Hz)")

    def prepare(self) -> None:
        """Start motulator's worker process before the instruments serve (the first capture
        then starts at once)."""
        with self.lock, self._worker_busy():
            self._configured_drive()

    def close(self) -> None:
        """End motulator's worker process (it also ends with this process); a stretch it is
        computing is abandoned first, without waiting for it."""
        with self._lock_abandoning("the bench was closed"):
            if self._drive is not None:
                self._drive.close()
                self._drive = None

    # ---- commands (the Plant contract) -----------------------------------------------------
    @property
    def injection(self) -> Injection:
        with self.lock:
            return self._injection

    def set_injection(self, **values) -> None:
        with self.lock:
            injection = self._injection.with_values(**values)
            defaults = Injection()
            for knob in UNSUPPORTED_KNOBS.get(PLANT, {}):
                reason = knob_refusal(PLANT, knob, getattr(injection, knob),
                                      getattr(defaults, knob))
                if reason:
                    raise ValueError(reason)
            self._injection = injection

    def restore_defaults(self) -> None:
        with self.lock:
            self._injection = Injection()

    @property
    def enabled(self) -> bool:
        with self.lock:
            return self._enabled

    def enable(self) -> None:
        with self.lock:
            self._enabled = True

    def disable(self) -> None:
        """Gates off. A stretch being computed (a capture: minutes of motulator) is abandoned
        at once, its capture failed: the drive it simulated is no longer the drive on the
        bench, and the DAQ's capture thread holds ``lock`` until it ends, so waiting for it
        would block the drive's CAN thread and every instrument's stop behind it."""
        with self._lock_abandoning("the drive was disabled during the capture"):
            self._enabled = False

    @property
    def current_command_a(self) -> float:
        with self.lock:
            return self._current_command_a

    @current_command_a.setter
    def current_command_a(self, value: float) -> None:
        value = float(value)
        if not 0.0 <= value <= 100.0:
            raise ValueError(f"current command {value!r} A outside 0..100 A")
        with self.lock:
            self._current_command_a = value

    @property
    def speed_rpm(self) -> float:
        with self.lock:
            return self._speed_rpm

    @speed_rpm.setter
    def speed_rpm(self, value: float) -> None:
        value = float(value)
        if not math.isfinite(value) or abs(value) > 20_000.0:
            raise ValueError(f"dyno speed {value!r} rpm outside -20000..20000 rpm")
        with self.lock:
            self._speed_rpm = value

    # ---- simulation ------------------------------------------------------------------------
    def advance(self, duration_s: float, sample_rate_hz: float, *, settle_s: float = 0.0,
                channels=None) -> dict[str, np.ndarray]:
        """Run ``settle_s`` unrecorded, then ``duration_s`` sampled at ``sample_rate_hz``
        (samples at t0 + k/rate, k = 0..n−1, n = ⌊duration·rate⌋)."""
        names = CHANNELS if channels is None else tuple(channels)
        unknown = [name for name in names if name not in CHANNELS]
        if unknown:
            raise ValueError(f"unknown channel {unknown[0]!r}; valid channels: "
                             f"{', '.join(CHANNELS)}")
        if not settle_s >= 0 or not duration_s >= 0 or not sample_rate_hz > 0:
            raise ValueError("settle_s and duration_s must be >= 0, sample_rate_hz > 0")
        with self.lock, self._worker_busy():
            drive = self._configured_drive()
            if settle_s > 0:
                self._run(drive, settle_s)
            n = int(math.floor(duration_s * sample_rate_hz + 1e-9))
            start = self.time_s
            history = self._run(drive, duration_s) if duration_s > 0 else None
            if n == 0 or history is None:
                return {name: np.zeros(0) for name in names}
            t = start + np.arange(n) / sample_rate_hz
            out = self._sampled(history, t, names)
            self._remember(history, out)
            return out

    def status(self) -> dict:
        with self.lock:
            cpr = self.config.sensors.encoder_counts_per_rev
            latest = {"torque_nm": 0.0, "torque_em_nm": 0.0, "speed_rpm": self._speed_rpm,
                      "position_counts": int(math.floor(self._angle_mech_rad * cpr
                                                        / (2 * math.pi))),
                      "ia_a": 0.0, "ib_a": 0.0, "dc_bus_v": self.motor.dc_bus_v}
            latest.update(self._latest)
            latest["time_s"] = self.time_s
            return latest

    # ---- motulator -------------------------------------------------------------------------
    def _applied(self) -> Injection:
        return self.defects.applied(self._injection) if self.defects.active else self._injection

    def _configured_drive(self):
        """motulator's drive with the present commands and the applied injection in place;
        the controller is rebuilt (integrators at zero) when the PWM frequency or the loop
        changes and when the gates are released."""
        from hil.plants.motulator_process import DriveProcess

        applied = self._applied()
        if self._drive is None:
            worker = DriveProcess()
            self._computing = worker          # its start-up (seconds) can be abandoned too
            worker.start(self.motor, self.time_s)
            self._drive = worker
        loop_hz = self.bandwidth_hz * self.defects.current_loop_bandwidth_scale
        self._drive.configure(applied, enabled=self._enabled,
                              current_a=self._current_command_a, speed_rpm=self._speed_rpm,
                              bandwidth_hz=loop_hz, design=self.design,
                              encoder_counts_per_rev=self.config.sensors.encoder_counts_per_rev)
        return self._drive

    @contextlib.contextmanager
    def _worker_busy(self):
        """While the worker starts, is configured or computes (``lock`` held): ``_computing``
        names it for ``_lock_abandoning``; afterwards a worker that was cancelled at any moment
        of it — even after its reply had arrived — is dropped, and the next stretch starts a
        new one (a review found a late cancel leaving every later ``advance`` refused)."""
        try:
            yield
        finally:
            for worker in (self._computing, self._drive):
                if worker is not None and worker.cancelled:
                    self._drive = None
            self._computing = None

    @contextlib.contextmanager
    def _lock_abandoning(self, reason: str):
        """``lock``, abandoning whatever stretch the worker computes meanwhile (``_run`` holds
        the lock while it computes; a stretch that starts while this waits is abandoned too):
        the worker is ended, that ``_run`` raises and the next stretch starts a new worker."""
        while not self.lock.acquire(timeout=LOCK_POLL_S):
            computing = self._computing
            if computing is not None:
                computing.cancel(reason)
        try:
            yield
        finally:
            self.lock.release()

    def _run(self, drive, duration_s: float):
        """Simulate ``duration_s`` from ``time_s``; the history (plant time) of that stretch."""
        self._computing = drive
        history = drive.run(self.time_s, duration_s)
        self.time_s = history.t_end
        self._angle_mech_rad = history.angle_end_rad
        history.torque_nm = self._transducer(history.t, history.tau)
        return history

    def _transducer(self, t: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """The bench transducer's front end on the torque history: first-order low-pass at
        ``transducer_bandwidth_hz`` (exact for a torque linear between solver points)."""
        if self.transducer_bandwidth_hz is None or len(t) == 0:
            return tau.copy()
        lag_s = 1.0 / (2 * math.pi * self.transducer_bandwidth_hz) \
            + self.defects.transducer_extra_lag_s
        y = np.empty_like(tau)
        prev = tau[0] if self._filter_nm is None else self._filter_nm
        y[0] = prev
        h = np.diff(t)
        a = np.exp(-h / lag_s)
        slope = np.divide(np.diff(tau), h, out=np.zeros_like(h), where=h > 0)
        for k in range(1, len(t)):
            ramp = slope[k - 1] * lag_s
            prev = tau[k] - ramp + (prev - tau[k - 1] + ramp) * a[k - 1]
            y[k] = prev
        self._filter_nm = float(prev)
        return y

    def _sampled(self, history, t: np.ndarray, names) -> dict[str, np.ndarray]:
        cpr = self.config.sensors.encoder_counts_per_rev
        out: dict[str, np.ndarray] = {}
        angle = np.interp(t, history.t, history.angle)
        for name in names:
            if name == "time_s":
                out[name] = t
            elif name == "rotor_angle_mech_rad":
                out[name] = angle
            elif name == "encoder_counts":
                out[name] = np.floor(angle * cpr / (2 * math.pi)).astype(np.int64)
            elif name == "speed_rpm":
                out[name] = np.full(len(t), self._speed_rpm)
            elif name == "dc_bus_v":
                out[name] = np.full(len(t), float(self.motor.dc_bus_v))
            elif name == "torque_nm":
                reading = np.interp(t, history.t, history.torque_nm) \
                    * (1.0 + self._gain_error_pu) * self.defects.transducer_scale
                out[name] = reading + self._rng.normal(0.0, TRANSDUCER_NOISE_RMS_NM, len(t))
            elif name in ("va_v", "vb_v", "vc_v"):
                out[name] = history.period_average(t, name)
            else:
                out[name] = np.interp(t, history.t, getattr(history, name))
        return out

    def _remember(self, history, out: dict) -> None:
        last = history.t[-1:]
        latest = {"torque_em_nm": float(history.tau[-1]),
                  "ia_a": float(history.ia_a[-1]), "ib_a": float(history.ib_a[-1])}
        if "torque_nm" in out and len(out["torque_nm"]):
            latest["torque_nm"] = float(out["torque_nm"][-1])
        else:
            latest["torque_nm"] = float(np.interp(last, history.t, history.torque_nm)[0]
                                        * (1.0 + self._gain_error_pu)
                                        * self.defects.transducer_scale)
        self._latest = latest

