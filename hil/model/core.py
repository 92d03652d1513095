"""Shared vocabulary of the predictions: the operating point, the result type, parameter checks.

Conventions (all sources): rotor electrical angle θ with phase-a back EMF e_a = E·sin θ
(paper eq 1, E the peak phase EMF = sqrt(2)·Ke·ω_m); ideal phase currents i_a = I·sin(θ − φ)
(eq 4, I the peak phase current, φ the lag of the current behind the EMF). The torque is
T = Σ e_x·i_x / ω_m (eq 7), whose mean for ideal currents is (3/2)·E·I·cos φ / ω_m =
K_t·I·cos φ — finite at standstill, so no division by ω_m is ever needed. E/ω_m follows from Ke
and its stated definition (``hil.motor.MotorParameters``). A point that needs more than V_dc/√3
of phase voltage (SVPWM's linear limit) is refused.
"""

from __future__ import annotations

import cmath
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from hil.errors import InputError
from hil.motor import TABLE_I, MotorParameters

#: Peak phase-current range of the contract's ``current_command_a``, amperes.
CURRENT_RANGE_A = (0.0, 100.0)
#: Dyno speed range of the contract, rpm.
SPEED_RANGE_RPM = (-3000.0, 3000.0)

#: Phase offsets o_x of phases a, b, c: e_x = E·sin(θ − o_x) (eqs 1-3).
PHASE_OFFSETS_RAD = np.array([0.0, 2 * math.pi / 3, -2 * math.pi / 3])

MEAN_TORQUE_BASE = "mean torque (3/2)·E·I·cos φ/ω_m at the operating point"


def check_range(name: str, value: Any, low: float, high: float, *, unit: str = "",
                low_open: bool = False) -> float:
    """Return ``value`` as float, or raise InputError naming ``name`` and the allowed range."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{name}={value!r} is not a number "
                         f"(allowed {low:g}..{high:g}{unit})") from None
    bad_low = number <= low if low_open else number < low
    if not math.isfinite(number) or bad_low or number > high:
        bracket = "(" if low_open else "["
        raise InputError(f"{name}={value!r} is out of range "
                         f"(allowed {bracket}{low:g}, {high:g}]{unit})")
    return number


@dataclass(frozen=True)
class OperatingPoint:
    """Where a prediction is made: dyno speed, peak phase-current amplitude, current angle φ.

    ``current_angle_rad`` φ is the lag of the current behind the back EMF (paper eq 4).
    ``dc_bus_v`` defaults to the motor's (Table I: 12 V). A point needing more phase voltage than
    V_dc/√3 (SVPWM's linear limit) is refused: the current is not regulated there and no closed
    form applies. ``allow_beyond_voltage_limit=True`` accepts it, for studies of what a drive does
    there (the predictions' assumptions then do not hold).
    """

    speed_rpm: float
    current_a: float
    current_angle_rad: float = 0.0
    motor: MotorParameters = TABLE_I
    dc_bus_v: float | None = None
    allow_beyond_voltage_limit: bool = False
    #: The R and L the drive's PI current loop was designed with (Kp = L·ωc, Ki = R·ωc), when
    #: they are not the motor's (a drive configured from a nameplate, on a motor measured to
    #: differ: issue 29); None: the motor's own, the pole-zero cancellation the models assume.
    loop_tuning: MotorParameters | None = None

    @property
    def loop_motor(self) -> MotorParameters:
        """The motor the PI's gains were designed for (``loop_tuning`` or the motor)."""
        return self.loop_tuning if self.loop_tuning is not None else self.motor

    def __post_init__(self) -> None:
        check_range("speed_rpm", self.speed_rpm, *SPEED_RANGE_RPM, unit=" rpm")
        check_range("current_a", self.current_a, *CURRENT_RANGE_A, unit=" A", low_open=True)
        check_range("current_angle_rad", self.current_angle_rad, -math.pi / 2, math.pi / 2,
                    unit=" rad")
        if not isinstance(self.motor, MotorParameters):
            raise InputError(f"motor must be a MotorParameters, got {type(self.motor).__name__}")
        if self.dc_bus_v is None:
            object.__setattr__(self, "dc_bus_v", self.motor.dc_bus_v)
        check_range("dc_bus_v", self.dc_bus_v, 0.0, 1000.0, unit=" V", low_open=True)
        object.__setattr__(self, "speed_rpm", float(self.speed_rpm))
        object.__setattr__(self, "current_a", float(self.current_a))
        object.__setattr__(self, "current_angle_rad", float(self.current_angle_rad))
        object.__setattr__(self, "dc_bus_v", float(self.dc_bus_v))
        self._check_voltage_limit()

    def _check_voltage_limit(self) -> None:
        """Refuse a point the drive cannot reach: |V| > V_dc/√3, SVPWM's linear limit, with V the
        steady phasor at the *signed* speed (reverse rotation under positive torque brakes and
        needs less than the motoring phasor ``voltage_phasor_peak_v``; hil.model.voltage)."""
        from hil.model.voltage import steady_voltage_phasor_peak_v

        needed = abs(steady_voltage_phasor_peak_v(self.motor, self.speed_rpm, self.current_a,
                                                  self.current_angle_rad))
        limit = self.dc_bus_v / math.sqrt(3.0)
        if needed <= limit * (1 + 1e-12) or self.allow_beyond_voltage_limit:
            return
        raise InputError(
            f"speed_rpm={self.speed_rpm:g} with current_a={self.current_a:g} at "
            f"{math.degrees(self.current_angle_rad):g}° needs a {needed:.3g} V peak phase voltage, "
            f"beyond the {limit:.3g} V (V_dc/√3, SVPWM) of the {self.dc_bus_v:g} V bus with Ke "
            f"read as {self.motor.ke_definition} (allowed: |speed_rpm| <= "
            f"{self.voltage_limited_speed_rpm():.0f} at this current)")

    def voltage_limited_speed_rpm(self) -> float:
        """Highest |speed| at which this current and angle stay within V_dc/√3 (SVPWM)."""
        motor = self.motor
        current = self.current_a * cmath.exp(-1j * self.current_angle_rad)
        # V(ω_m) = a·ω_m + b: EMF and reactance grow with speed, the resistive drop does not
        a = motor.emf_peak_v_s_per_rad + 1j * motor.pole_pairs * motor.phase_inductance_h * current
        b = motor.phase_resistance_ohm * current
        limit = self.dc_bus_v / math.sqrt(3.0)
        qa, qb, qc = abs(a) ** 2, 2 * (a * b.conjugate()).real, abs(b) ** 2 - limit ** 2
        if qc > 0:
            return 0.0
        omega = (-qb + math.sqrt(qb * qb - 4 * qa * qc)) / (2 * qa)
        return omega * 60.0 / (2.0 * math.pi)

    @property
    def voltage_phasor_peak_v(self) -> complex:
        """Peak phase-voltage phasor, angle from the EMF, that drives the current I∠−φ in steady
        state: V = E + (R + j·ω_e·L)·I·e^(−jφ) (the circuit of eq 27, peak values)."""
        motor = self.motor
        current = self.current_a * cmath.exp(-1j * self.current_angle_rad)
        reactance = abs(self.elec_speed_rad_s) * motor.phase_inductance_h
        return self.emf_peak_v + complex(motor.phase_resistance_ohm, reactance) * current

    @property
    def mech_speed_rad_s(self) -> float:
        return self.speed_rpm * 2.0 * math.pi / 60.0

    @property
    def elec_speed_rad_s(self) -> float:
        return self.mech_speed_rad_s * self.motor.pole_pairs

    @property
    def emf_peak_v(self) -> float:
        """Peak phase back EMF E = |ω_m| times the motor's peak EMF constant (eq 1)."""
        return self.motor.emf_peak_v_s_per_rad * abs(self.mech_speed_rad_s)

    @property
    def mean_torque_nm(self) -> float:
        """(3/2)·E·I·cos φ/ω_m = (3/2)·sqrt(2)·Ke·I·cos φ: the torque of ideal currents (eq 7, γ=0)."""
        return (self.motor.torque_constant_nm_per_a * self.current_a
                * math.cos(self.current_angle_rad))

    def to_dict(self) -> dict[str, float]:
        return {"speed_rpm": self.speed_rpm, "current_a": self.current_a,
                "current_angle_rad": self.current_angle_rad, "dc_bus_v": self.dc_bus_v}


@dataclass(frozen=True)
class Prediction:
    """A closed-form ripple prediction for one source at one operating point.

    ``pk_pk_pu`` is per unit of ``base_nm`` (described by ``base``); ``order`` is the electrical
    harmonic order of the dominant ripple (None = broadband); ``angle_rad``/``waveform_pu`` give the
    ripple (torque minus its mean, per unit of ``base_nm``) against electrical angle θ where the
    paper defines a waveform. ``extras`` holds secondary figures (e.g. the paper's own per-unit).
    ``expected_range_pu`` (low, high), per unit of ``base_nm``: where a derived model states its
    own uncertainty, the interval a drive that behaves as modelled falls in (None: not stated).
    """

    source: str
    pk_pk_pu: float
    base: str
    base_nm: float
    order: float | None
    inputs: dict[str, Any]
    equations: str
    assumptions: list[str] = field(default_factory=list)
    angle_rad: np.ndarray | None = None
    waveform_pu: np.ndarray | None = None
    extras: dict[str, Any] = field(default_factory=dict)
    expected_range_pu: tuple[float, float] | None = None

    @property
    def pk_pk_nm(self) -> float:
        return self.pk_pk_pu * self.base_nm

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict (arrays as lists)."""
        def plain(value: Any) -> Any:
            if isinstance(value, np.ndarray):
                return value.tolist()
            if isinstance(value, (np.floating, np.integer)):
                return value.item()
            if isinstance(value, dict):
                return {key: plain(item) for key, item in value.items()}
            return value
        return {"source": self.source, "pk_pk_pu": self.pk_pk_pu, "pk_pk_pct": 100 * self.pk_pk_pu,
                "pk_pk_nm": self.pk_pk_nm, "base": self.base, "base_nm": self.base_nm,
                "order": self.order, "equations": self.equations, "inputs": plain(self.inputs),
                "assumptions": list(self.assumptions), "extras": plain(self.extras),
                "expected_range_pu": (list(self.expected_range_pu)
                                      if self.expected_range_pu is not None else None),
                "angle_rad": plain(self.angle_rad), "waveform_pu": plain(self.waveform_pu)}


def angle_grid(points: int = 3600) -> np.ndarray:
    """Electrical angles θ over one revolution, [0, 2π), for waveforms."""
    return np.linspace(0.0, 2.0 * math.pi, points, endpoint=False)

