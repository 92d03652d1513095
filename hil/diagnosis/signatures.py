"""Forward signatures: the torque each source adds at each operating point, per unit parameter,
as complex coefficients per mechanical order (the convention of :mod:`hil.diagnosis.orders`).

Controller sources (inverses of ``hil.model``):

* **Sensor dc offsets** (eqs 15-19) and **gain mismatch** (eqs 21-25) are sensor errors n_a, n_b
  added to the measured currents. The firmware regulates the *measured* currents, so the actual
  current error is −T·n, with T the current loop's complementary sensitivity evaluated in the
  rotor frame (T = 1 is the paper's ideal regulation, for which these signatures equal
  ``hil.model.dc_offset.ripple_pu`` and the eq 24 ripple term exactly; tested). The torque is the
  paper's sum Σ e_x·i_x/ω_m (eq 7) written with space vectors: ΔT = (3/2)·k_e·Re(−j·e^{jθ}·Δī*),
  k_e = E/ω_m. An offset gives order 1; k_a − k_b gives order 2 at a fixed phase
  (sin(2θ − φ − 2π/3), eq 24); k_a + k_b moves only the mean. Gains are parameterised by the
  paper's k (actual-current error, 1 + k = 1/(1 + g) for a sensor gain error g), which makes the
  signature exact rather than first order in g.
* **Dead time** (eqs 32-38, the project's derived closed-loop form): the average-voltage model of
  ``hil.model.dead_time.average_model_torque_pu`` with the bench's current loop (its disturbance
  transfer, :func:`loop_disturbance`); orders 6, 12, …; linear in T_d.

**The current loop the bench states** (``DriveSetup.current_loop_*``, the bench file's [drive]
keys; the twin implements the same designs, hil.sim.config.FirmwareModel). Every transfer is
derived here from the loop gain :func:`loop_gain` in the rotor frame (complex vectors, plant
1/(R + L·(s + jω_e)), s the rotor-frame frequency): T = L/(1 + L) for a sensor error,
P/(1 + L) for a voltage disturbance. Designs: "continuous" PI (Kp = L·ω_c, Ki = R·ω_c),
"discrete" pole-matched PI run at the PWM rate (C(z) = Kp + Ki·T_s·z/(z − 1), z = e^{sT_s}),
"2dof" the complex-vector 2-DOF PI of Briz 2000 / Awan 2019 (feedback L·(2α + (α² + jω_e·α)/s),
α = ω_c: motulator's current controller; its integrator updated from the computed or from the
realised voltage, ``DriveSetup.current_loop_integrator_realised``, both among a stated loop's
variants; the continuous and 2-DOF equations are ``hil.current_loop``'s, the models' one place,
whose realised form C = (K_p·s + K_i)/(s + K_r·(1 − D)) is exact in the delay), and "unknown"
(the mean transfer over a family of
plausible loops, :meth:`DriveSetup.loop_variants`, whose spread the diagnosis propagates).
Decoupling adds −jω_e·L to the feedback (it cancels the plant's cross term with the measured
current); back-EMF feed-forward adds a current-independent voltage and changes no transfer; the
delay τ is e^{−(s + jω_e)τ} (the voltage is applied τ later at the angle it was computed for)
or e^{−sτ} with angle compensation.

Motor-side terms: **cogging** fixed in the mechanical angle and independent of current (a constant
complex coefficient per mechanical order), and **EMF-harmonic torque**, fixed in the electrical
angle and proportional to the current.

Every signature is passed through the torque transducer's first-order response at the ripple's
time frequency (a lag in angle for forward rotation, a lead backwards), when its bandwidth is known.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace

import numpy as np

from hil.current_loop import applied_delay, controller_response, loop_gains
from hil.errors import InputError
from hil.model import OperatingPoint
from hil.model.dead_time import average_model_torque_pu, loop_rejection
from hil.motor import TABLE_I, MotorParameters

#: Loop designs a bench file can state (``[drive] current_loop_design``).
LOOP_DESIGNS = ("continuous", "discrete", "2dof", "unknown")
#: A stated design is known to within this fraction of its stated bandwidth (and half a PWM
#: period of its delay): the variants whose spread is its model uncertainty.
STATED_LOOP_BANDWIDTH_FRACTION = 0.1
#: "unknown": the family spans these multiples of the stated bandwidth (0.5 to 5: a PI at half
#: the bandwidth to a near-ideal 2-DOF loop five times faster), each design, with and without
#: decoupling for the PIs.
UNKNOWN_LOOP_BANDWIDTH_FACTORS = (0.5, 1.0, 2.0, 5.0)
#: A plausible loop ("unknown" family): its bandwidth times its delay at most this many radians
#: (a PI's phase margin 90° − ω_c·τ ≥ ≈ 33°) and at most this fraction of the PWM frequency.
MAX_LOOP_BANDWIDTH_DELAY_RAD = 1.0
MAX_LOOP_BANDWIDTH_PER_PWM = 0.25
#: "unknown" without a stated bandwidth: this fraction of the PWM frequency (1 kHz at 20 kHz).
UNKNOWN_LOOP_BANDWIDTH_PER_PWM = 0.05
#: "unknown" without a stated delay: 1.5 PWM periods (one of computation, half of PWM hold).
UNKNOWN_LOOP_DELAY_PERIODS = 1.5

#: Angle grid (points per electrical revolution) on which waveforms are transformed.
GRID_POINTS = 256
SQRT3 = math.sqrt(3.0)


@dataclass(frozen=True)
class DriveSetup:
    """What the forward models need to know about the drive and the bench (SI units).

    ``current_loop_bandwidth_hz`` None means ideal current regulation (the paper's assumption),
    unless ``current_loop_design`` is "unknown" (then a family of plausible loops around
    :data:`UNKNOWN_LOOP_BANDWIDTH_PER_PWM` of the PWM frequency); ``transducer_bandwidth_hz``
    None means a flat transducer response. The loop's design and options: the module docstring.
    """

    motor: MotorParameters = TABLE_I
    current_loop_bandwidth_hz: float | None = None
    current_loop_delay_s: float = 0.0
    pwm_frequency_hz: float = 20_000.0
    transducer_bandwidth_hz: float | None = None
    #: Standard uncertainty (A) of the dc of the DAQ's phase-current channels (their own offset):
    #: when given, the captures' current dc is fitted too (it separates a sensor offset from a
    #: torque fixed in the rotor angle); None: the currents are not used.
    current_channel_u_a: float | None = None
    #: Upper bound (s) of the inverter's effective dead time, when the drive's documentation
    #: states it; with a coarse encoder it sizes the offsets' dwell term (hil.diagnosis.dwell).
    #: None: the larger of the fitted nuisance dead time × 3 (its 100 % model uncertainty at
    #: k = 2) and its fit interval estimate + 2u (hil.diagnosis.core._dwell_terms) is used;
    #: with neither above zero the dwell term is not applied, and the output says so.
    dead_time_bound_s: float | None = None
    #: "continuous" | "discrete" | "2dof" | "unknown" (module docstring)
    current_loop_design: str = "continuous"
    #: feed-forward of the dq cross terms ω_e·L·i with the measured currents
    current_loop_decoupling: bool = False
    #: feed-forward of the back EMF (changes no small-signal transfer; recorded)
    current_loop_emf_feedforward: bool = False
    #: inverse Park at the angle advanced by ω_e·delay (the delay rotates nothing)
    current_loop_angle_compensation: bool = False
    #: the 2-DOF loop's integrator updated from the *realised* voltage (back-calculation
    #: anti-windup u_i += T_s·(α + jω_e)·(u − v) fed with the voltage applied, one loop delay τ
    #: after it was computed; motulator's ComplexPIController) instead of the computed one: it
    #: also integrates −(1 − e^{−sτ})·u, so C = (K_p·s + K_i)/(s + (α + jω_e)·(1 − e^{−sτ}))
    #: (``hil.current_loop``), ≈ the computed form divided by 1 + (α + jω_e)·τ at low
    #: frequency. At a sensor error's rotor-frame frequency the correction T − 1 is
    #: dominated by the integral action (1/L ≈ −j·R·ω_e/(L·α²)), so it grows by that factor
    #: (1.3-1.6 on the issue-23 motulator drives). Not a bench-file key: a stated 2-DOF loop's
    #: variants include both forms (:meth:`loop_variants`), the drive runs one of them ("unknown":
    #: its family's bandwidths 0.5-5× already span a factor 1.6 of the integral action).
    current_loop_integrator_realised: bool = False
    #: The R and L the drive's loop gains were set from when the motor was measured to differ
    #: (the stated [motor] a drive was configured from, issue 29); None: ``motor``'s own.
    loop_tuning: MotorParameters | None = None

    def __post_init__(self) -> None:
        if self.current_loop_design not in LOOP_DESIGNS:
            raise InputError(f"current_loop_design={self.current_loop_design!r} must be one of "
                             f"{', '.join(LOOP_DESIGNS)}")
        for name in ("current_loop_decoupling", "current_loop_emf_feedforward",
                     "current_loop_angle_compensation", "current_loop_integrator_realised"):
            if not isinstance(getattr(self, name), bool):
                raise InputError(f"{name}={getattr(self, name)!r} must be true or false")
        for name in ("current_loop_bandwidth_hz", "transducer_bandwidth_hz"):
            value = getattr(self, name)
            if value is not None and not (math.isfinite(value) and value > 0):
                raise InputError(f"{name}={value!r} must be a positive frequency in Hz or None")
        if not (0 <= self.current_loop_delay_s < 1e-2):
            raise InputError(f"current_loop_delay_s={self.current_loop_delay_s!r} must be in "
                             "[0, 0.01) s")
        if self.current_channel_u_a is not None and not (
                math.isfinite(self.current_channel_u_a) and self.current_channel_u_a >= 0):
            raise InputError(f"current_channel_u_a={self.current_channel_u_a!r} must be >= 0 A "
                             "or None")
        if not 2000 <= self.pwm_frequency_hz <= 50_000:
            raise InputError(f"pwm_frequency_hz={self.pwm_frequency_hz!r} must be in "
                             "[2000, 50000] Hz")
        # a dead time of half a PWM period or more leaves no period for the commanded pulse
        limit_s = min(1e-4, 0.5 / self.pwm_frequency_hz)
        if self.dead_time_bound_s is not None and not (0 <= self.dead_time_bound_s < limit_s):
            raise InputError(f"dead_time_bound_s={self.dead_time_bound_s!r} must be in "
                             f"[0, {limit_s:.3g}) s (below half a PWM period at "
                             f"{self.pwm_frequency_hz:g} Hz) or None")

    def to_dict(self) -> dict:
        data = asdict(self)
        data["motor"] = asdict(self.motor)
        return data

    @property
    def loop_is_ideal(self) -> bool:
        """No loop stated and not "unknown": ideal regulation (T = 1)."""
        return not self.current_loop_bandwidth_hz and self.current_loop_design != "unknown"

    def loop_variants(self) -> list["DriveSetup"]:
        """The loops this setup's statement allows, each a concrete design (module docstring):
        a stated design at its bandwidth × (1 ± :data:`STATED_LOOP_BANDWIDTH_FRACTION`) and its
        delay ± half a PWM period; "unknown": continuous and discrete PI (with and without
        decoupling, no angle compensation) and the 2-DOF loop (angle compensation), each at the
        bandwidths :data:`UNKNOWN_LOOP_BANDWIDTH_FACTORS` × the stated (or default) bandwidth,
        at the stated (or default) delay, leaving out those a drive would not run (ω_c·τ above
        :data:`MAX_LOOP_BANDWIDTH_DELAY_RAD`, or above :data:`MAX_LOOP_BANDWIDTH_PER_PWM` of
        the PWM frequency; the stated bandwidth is always kept). Ideal regulation: none."""
        if self.loop_is_ideal:
            return []
        half_period = 0.5 / self.pwm_frequency_hz
        if self.current_loop_design != "unknown":
            out = [replace(self, current_loop_bandwidth_hz=self.current_loop_bandwidth_hz * f,
                           current_loop_delay_s=max(0.0, self.current_loop_delay_s + d))
                   for f in (1 - STATED_LOOP_BANDWIDTH_FRACTION,
                             1 + STATED_LOOP_BANDWIDTH_FRACTION)
                   for d in (-half_period, half_period)]
            if self.current_loop_design == "2dof":      # the other integrator update
                out.append(replace(self, current_loop_integrator_realised=not
                                   self.current_loop_integrator_realised))
            return out
        bandwidth = (self.current_loop_bandwidth_hz
                     or UNKNOWN_LOOP_BANDWIDTH_PER_PWM * self.pwm_frequency_hz)
        delay = self.current_loop_delay_s or UNKNOWN_LOOP_DELAY_PERIODS / self.pwm_frequency_hz
        out = []
        for factor in UNKNOWN_LOOP_BANDWIDTH_FACTORS:
            if (factor != 1.0 and (2 * math.pi * bandwidth * factor * delay
                                   > MAX_LOOP_BANDWIDTH_DELAY_RAD
                                   or bandwidth * factor
                                   > MAX_LOOP_BANDWIDTH_PER_PWM * self.pwm_frequency_hz)):
                continue                  # not a loop a drive would run with this delay
            common = dict(current_loop_bandwidth_hz=bandwidth * factor,
                          current_loop_delay_s=delay, current_loop_emf_feedforward=False)
            for design in ("continuous", "discrete"):
                for decoupling in (False, True):
                    out.append(replace(self, current_loop_design=design,
                                       current_loop_decoupling=decoupling,
                                       current_loop_angle_compensation=False, **common))
            out.append(replace(self, current_loop_design="2dof", current_loop_decoupling=False,
                               current_loop_angle_compensation=True, **common))
        return out

    def loop_text(self) -> str:
        """One line: the loop as stated."""
        if self.loop_is_ideal:
            return "ideal current regulation (no loop stated)"
        options = [name for name, on in (("decoupling", self.current_loop_decoupling),
                                         ("EMF feed-forward", self.current_loop_emf_feedforward),
                                         ("angle compensation",
                                          self.current_loop_angle_compensation)) if on]
        bandwidth = (f"{self.current_loop_bandwidth_hz:g} Hz" if self.current_loop_bandwidth_hz
                     else "bandwidth not stated")
        return (f"{self.current_loop_design} loop, {bandwidth}, delay "
                f"{self.current_loop_delay_s * 1e6:.3g} µs"
                + (f", {', '.join(options)}" if options else ""))


def operating_point(speed_rpm: float, current_a: float, current_angle_rad: float,
                    setup: DriveSetup) -> OperatingPoint:
    return OperatingPoint(speed_rpm=speed_rpm, current_a=current_a,
                          current_angle_rad=current_angle_rad, motor=setup.motor,
                          loop_tuning=setup.loop_tuning)


def discrete_pi_gains(resistance_ohm: float, inductance_h: float, bandwidth_rad_s: float,
                      period_s: float) -> tuple[float, float]:
    """(Kp in V/A, Ki in V/(A·s)) of the pole-matched discrete PI the bench file calls
    "discrete": the zero cancels the sampled plant pole a = e^{−R·T_s/L}, the delay-free
    closed-loop pole sits at e^{−ω_c·T_s}."""
    plant_pole = math.exp(-resistance_ohm * period_s / inductance_h)
    loop_gain_ = -math.expm1(-bandwidth_rad_s * period_s)
    return (plant_pole * resistance_ohm * loop_gain_ / (1.0 - plant_pole),
            resistance_ohm * loop_gain_ / period_s)


def loop_gain(rotor_frequency_rad_s, op: OperatingPoint, setup: DriveSetup):
    """Loop gain (controller's feedback part × delay × plant) of a concrete design at
    rotor-frame frequencies ω ≠ 0 (rad/s; array or number), module docstring."""
    motor, tuned = op.motor, op.loop_motor      # the plant; the motor the gains were set from
    r, l = motor.phase_resistance_ohm, motor.phase_inductance_h
    r_t, l_t = tuned.phase_resistance_ohm, tuned.phase_inductance_h
    w_e = op.elec_speed_rad_s
    w = np.asarray(rotor_frequency_rad_s, dtype=float)
    s = 1j * w
    design = setup.current_loop_design
    delay = applied_delay(w, w_e, setup.current_loop_delay_s,
                          setup.current_loop_angle_compensation)
    if design == "discrete":
        period = 1.0 / setup.pwm_frequency_hz
        kp, ki = discrete_pi_gains(r_t, l_t, 2 * math.pi * setup.current_loop_bandwidth_hz,
                                   period)
        z = np.exp(s * period)
        controller = kp + ki * period * z / (z - 1.0)
    elif design in ("continuous", "2dof"):   # hil.current_loop's equations
        gains = loop_gains(design, setup.current_loop_bandwidth_hz, resistance_ohm=r_t,
                           inductance_h=l_t, elec_speed_rad_s=w_e)
        if not setup.current_loop_integrator_realised:
            gains = replace(gains, realised_feedback_per_s=0j)
        controller = controller_response(gains, w, delay)
    else:
        raise InputError(f"loop_gain needs a concrete design, got {design!r}")
    if setup.current_loop_decoupling:
        controller = controller - 1j * w_e * l_t
    return controller * delay / (r + l * (s + 1j * w_e))


def _loop_transfer(rotor_frequency_rad_s, op, setup, kind: str):
    w = np.asarray(rotor_frequency_rad_s, dtype=float)
    if setup.current_loop_design == "unknown":
        values = np.mean([_loop_transfer(w, op, v, kind) for v in setup.loop_variants()], axis=0)
        return complex(values) if values.ndim == 0 else values
    motor = op.motor
    plant = 1.0 / (motor.phase_resistance_ohm
                   + motor.phase_inductance_h * (1j * w + 1j * op.elec_speed_rad_s))
    safe = np.where(w == 0.0, 1.0, w)
    gain = loop_gain(safe, op, setup)
    if kind == "tracking":      # the integrator tracks a constant error completely
        out = np.where(w == 0.0, 1.0 + 0j, gain / (1.0 + gain))
    else:                       # ... and rejects a constant disturbance completely
        out = np.where(w == 0.0, 0j, plant / (1.0 + gain))
    return complex(out) if out.ndim == 0 else out


def loop_tracking(rotor_frequency_rad_s, op: OperatingPoint, setup: DriveSetup):
    """Complementary sensitivity T of the current loop at a rotor-frame frequency: how much of a
    measurement error the loop writes into the actual current (1 for ideal regulation); for
    "unknown" the mean over :meth:`DriveSetup.loop_variants`."""
    if setup.loop_is_ideal:
        return 1.0 + 0j if np.ndim(rotor_frequency_rad_s) == 0 else \
            np.ones(np.shape(rotor_frequency_rad_s), dtype=complex)
    return _loop_transfer(rotor_frequency_rad_s, op, setup, "tracking")


def loop_disturbance(rotor_frequency_rad_s, op: OperatingPoint, setup: DriveSetup):
    """Voltage disturbance → current (A/V) in the rotor frame, P/(1 + L); voltage-fed (no loop)
    when no loop is stated (the average dead-time model's convention)."""
    if setup.loop_is_ideal:
        return loop_rejection(rotor_frequency_rad_s, op, None)
    return _loop_transfer(rotor_frequency_rad_s, op, setup, "disturbance")


def transducer_response(mech_order: int, speed_rpm: float, setup: DriveSetup) -> complex:
    """First-order transducer response at the time frequency of mechanical order m (signed)."""
    if not setup.transducer_bandwidth_hz:
        return 1.0 + 0j
    frequency_hz = mech_order * speed_rpm / 60.0
    return 1.0 / (1.0 + 1j * frequency_hz / setup.transducer_bandwidth_hz)


#: Grid for the dead-time model, whose harmonic series runs to n = 601 (no aliasing below 1024).
DEAD_TIME_GRID_POINTS = 2048


def electrical_grid(points: int = GRID_POINTS) -> np.ndarray:
    return np.arange(points) * (2 * math.pi / points)


def waveform_orders(torque_nm: np.ndarray) -> np.ndarray:
    """c_k (k = 0..GRID/2 − 1) with τ(θ) = Re Σ c_k e^{jkθ} of a waveform on an electrical grid
    (``torque_nm.size`` points; orders above GRID/2 − 1 of the default grid are dropped)."""
    spectrum = np.fft.rfft(torque_nm) / torque_nm.size
    spectrum[1:] *= 2.0
    return spectrum[: GRID_POINTS // 2]


def actual_current_error(op: OperatingPoint, setup: DriveSetup, n_a: np.ndarray,
                         n_b: np.ndarray) -> np.ndarray:
    """Space vector (A) of the actual current error on the grid caused by sensor errors n_a(θ),
    n_b(θ) (A). Two sensors, i_c computed (isolated neutral, eq 17): the firmware's space vector
    of the error is n_a + j·(n_a + 2·n_b)/√3; its harmonic e^{jmθ} is seen by the loop at
    (m − 1)·ω_e, and the loop writes −T times it into the actual current."""
    error = n_a + 1j * (n_a + 2.0 * n_b) / SQRT3
    harmonics = np.fft.fft(error) / GRID_POINTS
    m = np.fft.fftfreq(GRID_POINTS, 1.0 / GRID_POINTS)
    tracking = loop_tracking((m - 1.0) * op.elec_speed_rad_s, op, setup)
    return -np.fft.ifft(harmonics * tracking) * GRID_POINTS


def offset_current_dc(op: OperatingPoint, setup: DriveSetup, phase: str) -> complex:
    """dc of the actual phase currents per ampere of offset in sensor ``phase``, as
    dc_a + j·dc_b (A/A): −1 for its own phase under ideal regulation, rotated by the loop."""
    one, zero = np.ones(GRID_POINTS), np.zeros(GRID_POINTS)
    vector = actual_current_error(op, setup, *((one, zero) if phase == "a" else (zero, one)))
    dc = complex(np.mean(vector))
    return complex(dc.real, -0.5 * dc.real + 0.5 * SQRT3 * dc.imag)


def sensor_error_torque(op: OperatingPoint, setup: DriveSetup, n_a: np.ndarray,
                        n_b: np.ndarray) -> np.ndarray:
    """Electrical-order torque coefficients (N·m) of sensor errors n_a(θ), n_b(θ) (A) on the grid
    (:func:`actual_current_error` in the paper's torque sum, eq 7)."""
    theta = electrical_grid()
    actual_error = actual_current_error(op, setup, n_a, n_b)
    k_e = op.motor.emf_peak_v_s_per_rad
    torque = 1.5 * k_e * np.real(-1j * np.exp(1j * theta) * np.conj(actual_error))
    return waveform_orders(torque)


def reference_currents(op: OperatingPoint) -> tuple[np.ndarray, np.ndarray]:
    """Ideal phase currents i_a, i_b = I·sin(θ − φ − o_x) (eq 4) on the grid, A."""
    theta = electrical_grid()
    phi = op.current_angle_rad
    return (op.current_a * np.sin(theta - phi),
            op.current_a * np.sin(theta - phi - 2 * math.pi / 3))


def offset_orders(op: OperatingPoint, setup: DriveSetup, phase: str) -> np.ndarray:
    """Torque coefficients per ampere of dc offset in sensor ``phase`` ('a' or 'b')."""
    one, zero = np.ones(GRID_POINTS), np.zeros(GRID_POINTS)
    return sensor_error_torque(op, setup, *((one, zero) if phase == "a" else (zero, one)))


def gain_difference_orders(op: OperatingPoint, setup: DriveSetup) -> np.ndarray:
    """Torque coefficients per unit of k_a − k_b (actual-current errors, eqs 21-22): k_a = +½,
    k_b = −½, i.e. sensor errors n_x = −k_x·i_x."""
    i_a, i_b = reference_currents(op)
    return sensor_error_torque(op, setup, -0.5 * i_a, 0.5 * i_b)


def gain_sum_orders(op: OperatingPoint, setup: DriveSetup) -> np.ndarray:
    """Torque coefficients per unit of k_a + k_b (k_a = k_b = ½): the mean only (eq 24)."""
    i_a, i_b = reference_currents(op)
    return sensor_error_torque(op, setup, -0.5 * i_a, -0.5 * i_b)


def dead_time_orders(op: OperatingPoint, setup: DriveSetup) -> np.ndarray:
    """Torque coefficients per microsecond of effective dead time (average-voltage model with the
    bench's loop; hil.model.dead_time)."""
    theta = electrical_grid(DEAD_TIME_GRID_POINTS)
    torque_pu = average_model_torque_pu(
        theta, op, 1e-6, setup.pwm_frequency_hz, setup.current_loop_bandwidth_hz,
        setup.current_loop_delay_s,
        rejection=lambda w: loop_disturbance(w, op, setup))
    coefficients = waveform_orders(torque_pu * op.mean_torque_nm)
    coefficients[0] = 0.0          # the fundamental's loss moves the mean; not used
    return coefficients


def to_mech(electrical: np.ndarray, pole_pairs: int, max_mech_order: int) -> dict[int, complex]:
    """Electrical-order coefficients → {mechanical order p·k: coefficient} within the band."""
    out = {}
    for k in range(1, electrical.size):
        m = pole_pairs * k
        if m <= max_mech_order and abs(electrical[k]) > 0:
            out[m] = complex(electrical[k])
    return out
