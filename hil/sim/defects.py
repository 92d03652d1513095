"""Test-only defects of the simulated drive, for mutation testing of the test plans.

A real bench has none of these. Each one makes the simulated bench misbehave in a way a plan
ought to notice (issue 13 item 3): the drive acknowledges an injection but does not apply it, or
applies it mis-scaled; a current sensor carries an offset nobody injected; the firmware's word is
shorter or longer than commanded; the torque transducer (and the DAQ's torque channel) reads
scaled; the DAQ drops samples; (issue 21 item 8) the sensor injections land on the other phase,
a gain injection is applied as 1/(1 + g), the drive's encoder index is offset from the rotor's
electrical zero, the firmware compensates the dead time, the transducer lags more than the bench
file states, the current loop is slower than the bench file states; (issue 30) the DAQ's sample instants
jitter or its clock runs off the rate it states. ``DriveTwin(defects=...)``
applies them (see :meth:`applied` and :meth:`applied_config`), the
simulated DAQ server reads ``daq_drop_every_nth``, ``daq_sample_jitter_samples`` and
``daq_clock_scale``; the bench file states them in
``[simulation.defects]`` (allowed only with ``simulated = true``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace

from hil.errors import InputError
from hil.sim.injection import Injection

#: knobs scaled by ``injection_scale`` when set away from their default (word length has its own
#: defect; hall_mode is a switch, not a magnitude)
SCALED_KNOBS = tuple(name for name in Injection.FIELDS
                     if name not in ("hall_mode", "word_length_bits", "loop_test_amplitude_a",
                                     "loop_test_order"))    # the loop's test signal: no fault
_INTEGER_KNOBS = ("encoder_decimation", "pwm_period_counts")


@dataclass(frozen=True)
class DriveDefects:
    """Test-only defects of the simulated bench (mutation testing); a real bench has none."""

    #: knob names, or ("*",): acknowledged and read back, never applied
    ignore_injection: tuple[str, ...] = ()
    #: applied numeric injections x this (read-back shows the commanded value)
    injection_scale: float = 1.0
    #: current-sensor offsets present with nothing injected, A
    hidden_ia_offset_a: float = 0.0
    hidden_ib_offset_a: float = 0.0
    #: firmware runs with (injected word length + this) bits
    word_length_offset_bits: int = 0
    #: torque transducer reading (and the DAQ torque channel) x this
    transducer_scale: float = 1.0
    #: simulated DAQ silently drops every n-th sample (0 = never)
    daq_drop_every_nth: int = 0
    #: the a-sensor injections (offset, gain error) land on the b sensor and vice versa
    sensor_injection_swapped: bool = False
    #: a commanded sensor gain error g is applied as 1/(1 + g) − 1 (the reciprocal: for small g
    #: the sign of g flips, so the sign of k_a − k_b and the order-2 phase flip, eqs 21-25)
    gain_applied_inverse: bool = False
    #: the drive's encoder index sits this far (electrical rad) ahead of the rotor's electrical
    #: zero: the firmware's Park angle is θe + this, so the current sits at φ − this
    encoder_index_offset_rad: float = 0.0
    #: the DAQ's angle channel (its encoder counter) reads this far (electrical degrees) ahead of
    #: the rotor's electrical angle, whose zero is phase a's back-EMF rising zero crossing (a
    #: bench encoder mounted with an unknown commutation offset); the drive itself commutates
    #: correctly. Applied by the simulated DAQ (drivers/simulated/modbus_daq_server.py); the
    #: self-check's back-EMF angle reference measures it (hil.selfcheck.emf_angle_reference)
    encoder_commutation_offset_elec_deg: float = 0.0
    #: fraction (0..1) of the dead time's average-voltage error the firmware compensates; the
    #: twin runs with an effective dead time of (1 − this)·t_d (the average-voltage reading of a
    #: compensation, eqs 32-35: what is left near the current zero crossings is not modelled)
    dead_time_compensation_pu: float = 0.0
    #: the transducer's first-order time constant is this much longer than the bench file's
    #: ``[torque] bandwidth_hz`` says (s): its low-frequency lag grows by this
    transducer_extra_lag_s: float = 0.0
    #: the current loop's bandwidth is this × what the bench file states (< 1: slower)
    current_loop_bandwidth_scale: float = 1.0
    #: (issue 30) the simulated DAQ takes each sample up to this many sample periods early or
    #: late (uniform, in steps of 1/8 sample), while its time base and tick count stay nominal
    daq_sample_jitter_samples: float = 0.0
    #: (issue 30) the simulated DAQ's real sample rate is this × the rate it states and stamps
    #: (0.995: its clock runs 0.5 % slow)
    daq_clock_scale: float = 1.0

    def __post_init__(self) -> None:
        if isinstance(self.ignore_injection, (list, str)):
            object.__setattr__(self, "ignore_injection", _knob_names(self.ignore_injection))
        self._validate()

    # ---- construction ----------------------------------------------------------------------
    @classmethod
    def from_dict(cls, d: dict) -> "DriveDefects":
        """Defects from a table (bench file ``[simulation.defects]``, CLI ``--defect`` pairs).

        ``ignore_injection`` may be a list of knob names or one comma-separated string. Any bad
        key or value raises InputError naming it and what is allowed.
        """
        if not isinstance(d, dict):
            raise InputError(f"simulation.defects must be a table, got {type(d).__name__}")
        names = [f.name for f in fields(cls)]
        unknown = sorted(set(d) - set(names))
        if unknown:
            raise InputError(f"unknown simulated-drive defect(s) {unknown}; allowed: "
                             f"{', '.join(names)}")
        values = dict(d)
        if "ignore_injection" in values:
            values["ignore_injection"] = _knob_names(values["ignore_injection"])
        for name in ("injection_scale", "hidden_ia_offset_a", "hidden_ib_offset_a",
                     "transducer_scale", "encoder_index_offset_rad", "dead_time_compensation_pu",
                     "transducer_extra_lag_s", "current_loop_bandwidth_scale",
                     "encoder_commutation_offset_elec_deg", "daq_sample_jitter_samples",
                     "daq_clock_scale"):
            if name in values:
                values[name] = _number(name, values[name])
        for name in ("word_length_offset_bits", "daq_drop_every_nth"):
            if name in values:
                values[name] = _integer(name, values[name])
        for name in ("sensor_injection_swapped", "gain_applied_inverse"):
            if name in values:
                values[name] = _boolean(name, values[name])
        return cls(**values)

    def to_dict(self) -> dict:
        """Only the fields that differ from their default (empty: no defect)."""
        out = {}
        for f in fields(self):
            value = getattr(self, f.name)
            if value != f.default:
                out[f.name] = list(value) if isinstance(value, tuple) else value
        return out

    @property
    def active(self) -> bool:
        return bool(self.to_dict())

    def describe(self) -> str:
        """One line for a record or report: ``"injection_scale=1.2, daq_drop_every_nth=10"``."""
        return ", ".join(f"{key}={','.join(value) if isinstance(value, list) else value}"
                         for key, value in self.to_dict().items())

    # ---- what the drive applies -------------------------------------------------------------
    def applied(self, commanded: Injection) -> Injection:
        """The injection the defective drive actually runs with, given the commanded one.

        Order: ignored knobs fall back to their defaults; knobs set away from their default are
        scaled by ``injection_scale`` (integers rounded, all clipped to the knob's range); the
        hidden sensor offsets are added (clipped to ±20 A); a non-zero word length is moved by
        ``word_length_offset_bits`` (clipped to 6..32 bits; floating point stays floating).
        """
        if not self.active:
            return commanded
        ranges = Injection.ranges()
        values = commanded.as_dict()
        ignored = Injection.FIELDS if "*" in self.ignore_injection else self.ignore_injection
        for name in ignored:
            values[name] = ranges[name].default
        if self.injection_scale != 1.0:
            for name in SCALED_KNOBS:
                low, high, default, _ = ranges[name]
                if values[name] != default:
                    scaled = values[name] * self.injection_scale
                    if name in _INTEGER_KNOBS:
                        scaled = int(round(scaled))
                    values[name] = min(max(scaled, low), high)
        for name, hidden in (("ia_offset_a", self.hidden_ia_offset_a),
                             ("ib_offset_a", self.hidden_ib_offset_a)):
            low, high, _, _ = ranges[name]
            values[name] = min(max(values[name] + hidden, low), high)
        if values["word_length_bits"] and self.word_length_offset_bits:
            values["word_length_bits"] = int(min(max(
                values["word_length_bits"] + self.word_length_offset_bits, 6), 32))
        if self.sensor_injection_swapped:
            for a, b in (("ia_offset_a", "ib_offset_a"), ("ia_gain_error_pu", "ib_gain_error_pu")):
                values[a], values[b] = values[b], values[a]
        if self.gain_applied_inverse:
            for name in ("ia_gain_error_pu", "ib_gain_error_pu"):
                low, high, _, _ = ranges[name]
                values[name] = min(max(1.0 / (1.0 + values[name]) - 1.0, low), high)
        if self.encoder_index_offset_rad:
            low, high, _, _ = ranges["current_angle_rad"]
            values["current_angle_rad"] = min(max(
                values["current_angle_rad"] - self.encoder_index_offset_rad, low), high)
        if self.dead_time_compensation_pu:
            values["dead_time_s"] *= 1.0 - self.dead_time_compensation_pu
        return replace(commanded, **values)

    def applied_config(self, config):
        """The :class:`hil.sim.config.DriveConfig` the defective drive runs: the injection by
        :meth:`applied`; the transducer's bandwidth lowered so that its time constant
        1/(2π·f_c) grows by ``transducer_extra_lag_s``; the loop bandwidth (per PWM frequency)
        × ``current_loop_bandwidth_scale`` (clipped to the firmware model's 0.005..0.15)."""
        if not self.active:
            return config
        changes = {"injection": self.applied(config.injection)}
        if self.transducer_extra_lag_s:
            tau_s = 1.0 / (2.0 * math.pi * config.transducer.bandwidth_hz)
            changes["transducer"] = replace(
                config.transducer,
                bandwidth_hz=1.0 / (2.0 * math.pi * (tau_s + self.transducer_extra_lag_s)))
        if self.current_loop_bandwidth_scale != 1.0:
            scaled = config.firmware.bandwidth_per_pwm * self.current_loop_bandwidth_scale
            changes["firmware"] = replace(config.firmware,
                                          bandwidth_per_pwm=min(max(scaled, 0.005), 0.15))
        return replace(config, **changes)

    # ---- checks ------------------------------------------------------------------------------
    def _validate(self) -> None:
        for name in self.ignore_injection:
            if name != "*" and name not in Injection.FIELDS:
                raise InputError(f"simulation.defects.ignore_injection: unknown knob {name!r}; "
                                 f"allowed: '*' or {', '.join(Injection.FIELDS)}")
        for name, low, high in (("injection_scale", 0.0, 10.0), ("transducer_scale", 0.0, 10.0)):
            value = getattr(self, name)
            if not low < value <= high:
                raise InputError(f"simulation.defects.{name} = {value!r} is out of range; "
                                 f"allowed > {low:g} and <= {high:g}")
        for name in ("hidden_ia_offset_a", "hidden_ib_offset_a"):
            value = getattr(self, name)
            if not -20.0 <= value <= 20.0:
                raise InputError(f"simulation.defects.{name} = {value!r} A is out of range; "
                                 f"allowed -20..20 A")
        if not -16 <= self.word_length_offset_bits <= 16:
            raise InputError(f"simulation.defects.word_length_offset_bits = "
                             f"{self.word_length_offset_bits!r} is out of range; allowed -16..16")
        if not -math.pi <= self.encoder_index_offset_rad <= math.pi:
            raise InputError(f"simulation.defects.encoder_index_offset_rad = "
                             f"{self.encoder_index_offset_rad!r} is out of range; allowed "
                             f"-pi..pi electrical rad")
        if not -180.0 <= self.encoder_commutation_offset_elec_deg <= 180.0:
            raise InputError(f"simulation.defects.encoder_commutation_offset_elec_deg = "
                             f"{self.encoder_commutation_offset_elec_deg!r} is out of range; "
                             f"allowed -180..180 electrical degrees")
        if not 0.0 <= self.dead_time_compensation_pu <= 1.0:
            raise InputError(f"simulation.defects.dead_time_compensation_pu = "
                             f"{self.dead_time_compensation_pu!r} is out of range; allowed 0..1")
        if not 0.0 <= self.transducer_extra_lag_s <= 0.1:
            raise InputError(f"simulation.defects.transducer_extra_lag_s = "
                             f"{self.transducer_extra_lag_s!r} s is out of range; allowed 0..0.1 s")
        if not 0.05 <= self.current_loop_bandwidth_scale <= 2.0:
            raise InputError(f"simulation.defects.current_loop_bandwidth_scale = "
                             f"{self.current_loop_bandwidth_scale!r} is out of range; allowed "
                             f"0.05..2")
        for name, low, high, unit in (("daq_sample_jitter_samples", 0.0, 0.5, " sample periods"),
                                      ("daq_clock_scale", 0.9, 1.1, "")):
            if not low <= getattr(self, name) <= high:
                raise InputError(f"simulation.defects.{name} = {getattr(self, name)!r} is out "
                                 f"of range; allowed {low:g}..{high:g}{unit}")
        for name in ("sensor_injection_swapped", "gain_applied_inverse"):
            if not isinstance(getattr(self, name), bool):
                raise InputError(f"simulation.defects.{name} = {getattr(self, name)!r} must be "
                                 f"true or false")
        if self.daq_drop_every_nth != 0 and not 2 <= self.daq_drop_every_nth <= 1_000_000:
            raise InputError(f"simulation.defects.daq_drop_every_nth = "
                             f"{self.daq_drop_every_nth!r} is out of range; allowed 0 (never) "
                             f"or 2..1000000")


def parse_defect_option(text: str) -> tuple[str, object]:
    """``"KEY=VALUE"`` of a ``--defect`` / ``--hil-sim-defect`` option -> (key, value).

    VALUE is read as a TOML value where it is one (``1.05``, ``10``, ``true``), else as a string
    (``ignore_injection=dead_time_s,ia_offset_a``); :meth:`DriveDefects.from_dict` checks it.
    """
    import tomllib

    key, sep, raw = text.partition("=")
    key, raw = key.strip(), raw.strip()
    if not sep or not key or not raw:
        raise InputError(f"defect {text!r} must be written KEY=VALUE, e.g. injection_scale=1.2")
    try:
        value = tomllib.loads(f"v = {raw}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw
    return key, value


def _knob_names(value) -> tuple[str, ...]:
    if isinstance(value, str):
        value = [part.strip() for part in value.split(",") if part.strip()]
    if not isinstance(value, (list, tuple)) or not all(isinstance(v, str) for v in value):
        raise InputError(f"simulation.defects.ignore_injection = {value!r} must be a list of "
                         f"knob names (or \"*\")")
    return tuple(value)


def _number(name: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise InputError(f"simulation.defects.{name} = {value!r} must be a finite number")
    return float(value)


def _boolean(name: str, value) -> bool:
    if not isinstance(value, bool):
        raise InputError(f"simulation.defects.{name} = {value!r} must be true or false")
    return value


def _integer(name: str, value) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise InputError(f"simulation.defects.{name} = {value!r} must be an integer")
    return value
