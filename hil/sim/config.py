"""The parts of the simulated drive, each a dataclass of parameters with Table I defaults.

``DriveConfig`` composes them with the injected faults and the operating command. The defaults
are the baseline drive: no fault, floating-point firmware, full encoder resolution, the paper's
air-gap-winding motor (sinusoidal EMF, no cogging).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from hil.motor import MotorParameters
from hil.sim.injection import Injection


@dataclass(frozen=True)
class MotorModel:
    """Three-phase star-connected PMSM (Table I) with optional EMF harmonics and cogging.

    ``emf_harmonics``: ((electrical order h, amplitude per unit of the fundamental EMF,
    phase rad), ...) added to the sinusoidal EMF e_a = E·sin(θe); at most 4 entries.
    ``cogging``: ((mechanical order, amplitude N·m, phase rad), ...), at most 2 entries:
    T_cog = A·sin(k·θm + phase). ``neutral_connected``: neutral tied to the dc-bus midpoint
    (zero-sequence current can flow) instead of isolated (the Table I motor).
    ``saturation_current_a``: the inductance falls with the current vector's magnitude,
    L(|i|) = L/(1 + (|i|/i_sat)²) (0: linear; isotropic, evaluated once per PWM period).
    ``thermal_time_constant_s`` and ``resistance_rise_pu_per_a2``: the winding warms with its
    copper loss, R = R·(1 + w) with τ·dw/dt = k·|i|² − w (τ = 0: no warming; the rise starts at
    0 when the twin is built). See ``kernel.plant_rl``.
    """

    parameters: MotorParameters = field(default_factory=MotorParameters)
    emf_harmonics: tuple[tuple[int, float, float], ...] = ()
    cogging: tuple[tuple[int, float, float], ...] = ()
    neutral_connected: bool = False
    saturation_current_a: float = 0.0
    thermal_time_constant_s: float = 0.0
    resistance_rise_pu_per_a2: float = 0.0

    def __post_init__(self) -> None:
        for name in ("saturation_current_a", "thermal_time_constant_s",
                     "resistance_rise_pu_per_a2"):
            if not getattr(self, name) >= 0:
                raise ValueError(f"MotorModel.{name} must be >= 0, got {getattr(self, name)!r}")
        if len(self.emf_harmonics) > 4:
            raise ValueError("MotorModel.emf_harmonics takes at most 4 (order, pu, phase) entries")
        for order, amplitude, _ in self.emf_harmonics:
            if int(order) != order or order < 2:
                raise ValueError(f"MotorModel.emf_harmonics order must be an integer >= 2, "
                                 f"got {order!r}")
            if not 0 <= amplitude <= 0.5:
                raise ValueError(f"MotorModel.emf_harmonics amplitude must be in [0, 0.5] pu, "
                                 f"got {amplitude!r}")
        if len(self.cogging) > 2:
            raise ValueError("MotorModel.cogging takes at most 2 (mech order, N·m, phase) entries")
        for order, amplitude, _ in self.cogging:
            if int(order) != order or order < 1:
                raise ValueError(f"MotorModel.cogging mechanical order must be an integer >= 1, "
                                 f"got {order!r}")


@dataclass(frozen=True)
class InverterModel:
    """Two-level inverter with a centre-aligned PWM up/down counter.

    ``modulation``: "svpwm" (min-max zero-sequence injection) or "sine" (sine-triangle, no
    zero sequence). PWM counts, frequency and dead time are injection knobs (see Injection).
    The dc bus voltage is the motor's ``dc_bus_v`` (Table I: 12 V, stiff).
    """

    modulation: str = "svpwm"

    def __post_init__(self) -> None:
        if self.modulation not in ("svpwm", "sine"):
            raise ValueError(f"InverterModel.modulation must be 'svpwm' or 'sine', "
                             f"got {self.modulation!r}")


LOOP_DESIGNS = ("continuous", "discrete")
LOOP_DELAYS_PERIODS = (0.0, 0.5, 1.0, 1.5)


@dataclass(frozen=True)
class FirmwareModel:
    """FOC current loop executed once per PWM period; the default is the twin's original loop.

    Bandwidth ωc = 2π·``bandwidth_per_pwm``·f_pwm (it scales with the PWM frequency knob).
    ``design``: "continuous" — PI designed in s by pole-zero cancellation of the R-L phase,
    Kp = L·ωc, Ki = R·ωc, run with an integrator that adds the present error before the output
    (Kp + Ki·Ts·z/(z − 1), ``firmware._pi_axis``; open loop ≈ ωc·Ts/(z − 1) per sample);
    "discrete" — pole-matched in z: the PI's zero cancels the ZOH-sampled plant pole
    a = exp(−R·Ts/L) and the delay-free closed-loop pole sits at exp(−ωc·Ts), so
    Kp = a·R·(1 − e^(−ωc·Ts))/(1 − a), Ki·Ts = R·(1 − e^(−ωc·Ts)) (see ``gains``). At the same
    ωc the discrete design has the lower loop gain, 1 − e^(−ωc·Ts) against ωc·Ts (0.40 vs 0.50
    at the default 0.08 per PWM period): the continuous design run at the PWM rate overshoots
    its nominal bandwidth.
    ``delay_periods``: computation delay between the current sample and the compare update:
    1 (default: sampled at the counter valley, applied from the next period), 0 (applied in the
    same period, an ideal instant computation), 0.5 (sampled at the counter peak, applied at the
    next valley) or 1.5 (sampled at the peak, applied at the valley after next). The PWM's
    average voltage adds half a period, so the total loop delay is (delay_periods + 0.5)/f_pwm
    (1.5 periods by default: phase margin 90° − 1.5·ωc·Ts rad ≈ 47° at 0.08).
    ``decoupling``: feed-forward of the dq cross terms (v_d += ωe·L·i_q, v_q −= ωe·L·i_d with the
    measured currents); ``emf_feedforward``: v_q += E = ψ·ω_m (the nameplate EMF constant);
    ``angle_compensation``: the inverse Park uses the angle advanced by ωe·(delay_periods + 0.5)/
    f_pwm, rounded to the sine table. The speed these use is the dyno's (an ideal estimate).
    ``sine_table_size`` entries of sin over one electrical revolution (index = truncated angle).
    ``tuning``: the motor the firmware's gains, decoupling and feed-forward were set for (a
    drive configured from a nameplate); None: the simulated motor itself.
    """

    bandwidth_per_pwm: float = 0.08
    sine_table_size: int = 4096
    design: str = "continuous"
    delay_periods: float = 1.0
    decoupling: bool = False
    emf_feedforward: bool = False
    angle_compensation: bool = False
    tuning: MotorParameters | None = None

    def __post_init__(self) -> None:
        if not 0.005 <= self.bandwidth_per_pwm <= 0.15:
            raise ValueError(f"FirmwareModel.bandwidth_per_pwm must be in [0.005, 0.15], "
                             f"got {self.bandwidth_per_pwm!r}")
        if not 64 <= self.sine_table_size <= 1 << 20:
            raise ValueError(f"FirmwareModel.sine_table_size must be in [64, 1048576], "
                             f"got {self.sine_table_size!r}")
        if self.design not in LOOP_DESIGNS:
            raise ValueError(f"FirmwareModel.design must be one of {LOOP_DESIGNS}, "
                             f"got {self.design!r}")
        if self.delay_periods not in LOOP_DELAYS_PERIODS:
            raise ValueError(f"FirmwareModel.delay_periods must be one of "
                             f"{LOOP_DELAYS_PERIODS} PWM periods, got {self.delay_periods!r}")
        for name in ("decoupling", "emf_feedforward", "angle_compensation"):
            if not isinstance(getattr(self, name), bool):
                raise ValueError(f"FirmwareModel.{name} must be True or False, "
                                 f"got {getattr(self, name)!r}")

    def gains(self, motor: MotorParameters, pwm_frequency_hz: float) -> tuple[float, float]:
        """(Kp in V/A, Ki in V/(A·s)) for the given PWM frequency (see the class docstring)."""
        omega_c = 2.0 * math.pi * self.bandwidth_per_pwm * pwm_frequency_hz
        resistance = motor.phase_resistance_ohm
        if self.design == "continuous":
            return motor.phase_inductance_h * omega_c, resistance * omega_c
        period_s = 1.0 / pwm_frequency_hz
        plant_pole = math.exp(-resistance * period_s / motor.phase_inductance_h)
        loop_gain = -math.expm1(-omega_c * period_s)             # 1 − e^(−ωc·Ts)
        kp = plant_pole * resistance * loop_gain / (1.0 - plant_pole)
        return kp, resistance * loop_gain / period_s

    def total_delay_s(self, pwm_frequency_hz: float) -> float:
        """Loop delay from a current sample to the mean of the voltage it sets, s."""
        return (self.delay_periods + 0.5) / pwm_frequency_hz


@dataclass(frozen=True)
class SensorModel:
    """Phase-current ADC and position sensor (fixed drive configuration of COMMON.md).

    Two current sensors (phases a and b) through a ``adc_bits`` ADC spanning ±``adc_full_scale_a``;
    an incremental encoder of ``encoder_counts_per_rev`` counts per mechanical revolution whose
    count 0 is aligned with θe = 0 (e_a = E·sin θe).
    """

    adc_bits: int = 12
    adc_full_scale_a: float = 100.0
    encoder_counts_per_rev: int = 7200

    def __post_init__(self) -> None:
        if not 6 <= self.adc_bits <= 24:
            raise ValueError(f"SensorModel.adc_bits must be in [6, 24], got {self.adc_bits!r}")
        if not self.adc_full_scale_a > 0:
            raise ValueError(f"SensorModel.adc_full_scale_a must be > 0, "
                             f"got {self.adc_full_scale_a!r}")
        if self.encoder_counts_per_rev < 4:
            raise ValueError(f"SensorModel.encoder_counts_per_rev must be >= 4, "
                             f"got {self.encoder_counts_per_rev!r}")


DYNO_MODES = ("constant", "ramp", "stepping")


@dataclass(frozen=True)
class DynoModel:
    """The load machine holding the shaft speed (stiff: speed is imposed, not integrated).

    "constant": the speed is the setpoint. "ramp": the speed slews to the setpoint at
    ``ramp_rpm_per_s``. "stepping" (zero-speed encoder experiment): the rotor dwells
    ``dwell_s`` then moves ``step_mech_rad`` at the setpoint speed, and repeats.
    """

    mode: str = "constant"
    ramp_rpm_per_s: float = 20000.0
    step_mech_rad: float = 2.0 * math.pi / 7200.0
    dwell_s: float = 0.01

    def __post_init__(self) -> None:
        if self.mode not in DYNO_MODES:
            raise ValueError(f"DynoModel.mode must be one of {DYNO_MODES}, got {self.mode!r}")
        if not self.ramp_rpm_per_s > 0:
            raise ValueError(f"DynoModel.ramp_rpm_per_s must be > 0, got {self.ramp_rpm_per_s!r}")
        if not self.step_mech_rad > 0 or not self.dwell_s >= 0:
            raise ValueError("DynoModel.step_mech_rad must be > 0 and dwell_s >= 0")


@dataclass(frozen=True)
class TransducerModel:
    """In-line shaft torque transducer: first-order bandwidth, white noise, accuracy class.

    The accuracy class becomes a fixed gain error drawn uniformly in ±class/100 of the reading
    from the seed, as an uncalibrated unit on a bench; below full scale that error lies inside
    the ±class % of full scale that the uncertainty budget (hil.analysis) assumes, so the budget
    is conservative for the simulated unit. The noise is Gaussian with ``noise_rms_nm`` per
    output sample.
    """

    bandwidth_hz: float = 1000.0
    noise_rms_nm: float = 2e-4
    accuracy_class_pct: float = 0.1

    def __post_init__(self) -> None:
        if not self.bandwidth_hz > 0:
            raise ValueError(f"TransducerModel.bandwidth_hz must be > 0, got {self.bandwidth_hz!r}")
        if not self.noise_rms_nm >= 0 or not self.accuracy_class_pct >= 0:
            raise ValueError("TransducerModel.noise_rms_nm and accuracy_class_pct must be >= 0")


@dataclass(frozen=True)
class DriveConfig:
    """One drive under test on the dyno: its parts, the injected faults and the operating point.

    ``current_command_a``: peak phase-current amplitude commanded (0..100 A); ``speed_rpm``: the
    dyno speed (-3000..3000 rpm); ``enabled``: gates on (False: gates off, no current).
    """

    motor: MotorModel = field(default_factory=MotorModel)
    inverter: InverterModel = field(default_factory=InverterModel)
    firmware: FirmwareModel = field(default_factory=FirmwareModel)
    sensors: SensorModel = field(default_factory=SensorModel)
    dyno: DynoModel = field(default_factory=DynoModel)
    transducer: TransducerModel = field(default_factory=TransducerModel)
    injection: Injection = field(default_factory=Injection)
    current_command_a: float = 10.0
    speed_rpm: float = 300.0
    enabled: bool = True

    def __post_init__(self) -> None:
        check_current_command(self.current_command_a)
        check_speed(self.speed_rpm)


def check_current_command(value: float) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 <= value <= 100:
        raise ValueError(f"current_command_a={value!r} is outside the allowed range [0, 100] A")
    return float(value)


def check_speed(value: float) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) \
            or not -3000 <= value <= 3000:
        raise ValueError(f"speed_rpm={value!r} is outside the allowed range [-3000, 3000] rpm")
    return float(value)
