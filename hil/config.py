"""The bench file: a TOML description of one test bench, validated on load.

Sections (design.md section 4): ``[motor]`` (Table I defaults), ``[drive]`` (python-can bus and
CANopen node), ``[daq]`` (Modbus TCP or RTU), ``[torque]`` (serial torque transducer),
``[limits]``, ``[operating_point]``, ``[[instrument]]`` (identity, accuracy and calibration of
each instrument), ``[lab]`` (for the report) and the top-level ``simulated`` flag.

Only ``tomllib`` parses the file: no code is evaluated. Every key is checked for type and range;
an unknown key (most often a typo) is refused. Errors are :class:`hil.errors.InputError` naming
the key path (``daq.port``), the bad value and what is allowed.

On a simulated bench (``simulated = true``) the instrument addresses may be left out: whoever
starts the simulated instruments fills them in with :meth:`BenchConfig.with_overrides`.
"""

from __future__ import annotations

import dataclasses
import difflib
import hashlib
import json
import math
import re
import tomllib
from dataclasses import dataclass, field, fields
from datetime import date
from importlib import resources
from pathlib import Path
from typing import Any, NoReturn

from hil import plausibility
from hil.current_loop import LOOP_DESIGNS, pi_equivalent_bandwidth_hz
from hil.errors import InputError
from hil.motor import KE_DEFINITIONS, MotorParameters
from hil.python_can import can

#: python-can interface names accepted in ``drive.interface``.
CAN_INTERFACES: tuple[str, ...] = tuple(sorted(can.interfaces.VALID_INTERFACES))
#: CiA 301 standard CAN bit rates, bit/s.
CAN_BITRATES: tuple[int, ...] = (10_000, 20_000, 50_000, 125_000, 250_000, 500_000, 800_000,
                                 1_000_000)
#: Serial line rates accepted for Modbus RTU and the torque transducer, baud.
SERIAL_BAUDRATES: tuple[int, ...] = (1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200,
                                     230400, 460800, 921600)
TORQUE_DIALECTS: tuple[str, ...] = ("magtrol", "himmelstein")
DAQ_TRANSPORTS: tuple[str, ...] = ("tcp", "rtu")
#: Modbus RTU line: parity (even, odd, none) and stop bits; 8 data bits always.
DAQ_PARITIES: tuple[str, ...] = ("E", "O", "N")
DAQ_STOPBITS: tuple[int, ...] = (1, 2)
INSTRUMENT_ROLES: tuple[str, ...] = ("drive", "daq", "torque", "dyno", "acquisition")

_ALWAYS, _REAL, _OPTIONAL = "always", "real", "optional"


@dataclass(frozen=True)
class _Spec:
    """How one bench-file key is checked: its kind, inclusive range or choices, and need."""

    kind: str                      # int | float | str | bool | path | date | channel
    lo: float | None = None
    hi: float | None = None
    choices: tuple | None = None
    required: str = _OPTIONAL      # always | real (required unless simulated) | optional


def _key(default: Any, kind: str, **spec: Any) -> Any:
    return field(default=default, metadata={"spec": _Spec(kind, **spec)})


# --------------------------------------------------------------------------- sections

@dataclass(frozen=True)
class MotorIdentity:
    """The motor under test as named on its nameplate (for the report), from ``[motor]``."""

    model: str = _key("", "str")
    serial_number: str = _key("", "str")


@dataclass(frozen=True)
class DriveConfig:
    """``[drive]``: the drive under test on a CAN bus (python-can) as CANopen node ``node_id``."""

    interface: str = _key("virtual", "str", choices=CAN_INTERFACES, required=_REAL)
    channel: str | int | None = _key(None, "channel", required=_REAL)
    bitrate: int = _key(500_000, "int", choices=CAN_BITRATES)
    node_id: int = _key(1, "int", lo=1, hi=127)
    eds: Path | None = _key(None, "path")  # None: the EDS shipped with the drivers
    #: Drive profile (docs/drive-profile.md): which EDS object carries each injection knob.
    profile: Path | None = _key(None, "path")  # None: the shipped drive's profile
    sdo_timeout_s: float = _key(0.5, "float", lo=0.01, hi=10.0)
    heartbeat_timeout_s: float = _key(1.0, "float", lo=0.05, hi=30.0)
    #: The drive's closed current-loop bandwidth and loop delay at its default PWM frequency,
    #: from its firmware documentation: the dead-time and PWM-resolution predictions need them
    #: (the loop rejects those voltage disturbances). None: not stated.
    current_loop_bandwidth_hz: float | None = _key(None, "float", lo=1.0, hi=50_000.0)
    current_loop_delay_s: float | None = _key(None, "float", lo=0.0, hi=0.01)
    #: How the firmware's current loop is built (what the simulated bench's twin runs; on a real
    #: bench they document the firmware): PI designed in s ("continuous": Kp = L·ωc, Ki = R·ωc),
    #: pole-matched in z ("discrete"), or the complex-vector 2-DOF PI of Briz 2000 / Awan 2019
    #: ("2dof": u = α·L·i_ref − 2α·L·i + (α + jωe)·α·L/s·(i_ref − i), integrator fed from the
    #: realised voltage; motulator's current controller; equations and source:
    #: ``hil.current_loop``; the ripple-hil twin runs the two PIs only); dq decoupling
    #: (−ωe·L·i cross terms) and back-EMF
    #: feed-forward on/off; computation delay from the current sample to the compare update in
    #: PWM periods (0, 0.5, 1 or 1.5; the PWM adds half a period, so current_loop_delay_s =
    #: (current_loop_delay_periods + 0.5) / f_pwm); inverse-Park angle advanced by ωe × that
    #: delay (angle compensation) on/off.
    current_loop_design: str = _key("continuous", "str", choices=LOOP_DESIGNS)
    current_loop_decoupling: bool = _key(False, "bool")
    current_loop_emf_feedforward: bool = _key(False, "bool")
    current_loop_delay_periods: float = _key(1.0, "float", choices=(0.0, 0.5, 1.0, 1.5))
    current_loop_angle_compensation: bool = _key(False, "bool")
    #: The label the unit under test carries for the drive's serial number 0x1018:04, as a
    #: Python format of ``serial`` (e.g. "EPS-A-{serial:04d}"): a stated or scanned DUT serial
    #: is checked against it before the bench is driven (``hil.dut``). None: not stated.
    serial_label: str | None = _key(None, "str")

    def current_loop_equivalent_bandwidth_hz(self, pwm_frequency_hz: float = 20_000.0
                                             ) -> float | None:
        """Bandwidth of the continuous-design PI (Kp = L·ωc, Ki = R·ωc) that the PI-only
        closed-form predictions assume, with the same integral gain as the stated loop (what
        rejects the low-order PWM-resolution and word-length disturbances):
        ``hil.current_loop.pi_equivalent_bandwidth_hz``. A ``"2dof"`` loop has no such PI: its
        stated α_c/(2π) is returned, its reference-tracking bandwidth (the design's closed loop
        is α_c/(s + α_c)), for the loop-lag bounds of the order phases; the PI-only models
        refuse it (``hil.validity``). None when the bandwidth is not stated."""
        if self.current_loop_design == "2dof":
            return self.current_loop_bandwidth_hz
        return pi_equivalent_bandwidth_hz(self.current_loop_design,
                                          self.current_loop_bandwidth_hz, pwm_frequency_hz)


@dataclass(frozen=True)
class DaqConfig:
    """``[daq]``: the Modbus data-acquisition unit, over TCP (host/port) or RTU (serial).

    RTU line: 8 data bits, ``parity`` and ``stopbits`` (default 8E1, the Modbus serial-line
    default; 8N2 and 8N1 selectable). TCP: ``requests_in_flight`` buffer reads outstanding at once
    (1 for a DAQ that cannot take pipelined requests).
    """

    transport: str = _key("tcp", "str", choices=DAQ_TRANSPORTS)
    host: str | None = _key(None, "str")
    port: int | None = _key(None, "int", lo=1, hi=65535)
    serial_port: str | None = _key(None, "str")
    baudrate: int | None = _key(None, "int", choices=SERIAL_BAUDRATES)
    unit_id: int = _key(1, "int", lo=0, hi=255)
    register_map: Path | None = _key(None, "path")  # None: the map shipped with the drivers
    timeout_s: float = _key(1.0, "float", lo=0.01, hi=30.0)
    parity: str = _key("E", "str", choices=DAQ_PARITIES)
    stopbits: int = _key(1, "int", choices=DAQ_STOPBITS)
    requests_in_flight: int = _key(8, "int", lo=1, hi=64)
    #: The angle channel's electrical angle (degrees) at which phase a's back EMF crosses zero
    #: going positive (the bench encoder's commutation offset; hil/diagnosis/README.md), when
    #: known: the self-check measures it and fails when the two disagree beyond its uncertainty.
    #: None: not stated (the self-check's measurement is recorded and used).
    emf_a_rising_zero_elec_deg: float | None = _key(None, "float", lo=-180.0, hi=180.0)

    def _check(self, path: str, ctx: "_Context") -> None:
        need, other = (("host", "port"), ("serial_port", "baudrate")) if self.transport == "tcp" \
            else (("serial_port", "baudrate"), ("host", "port"))
        line_only = {"tcp": ("parity", "stopbits"), "rtu": ("requests_in_flight",)}
        for name in line_only[self.transport]:
            default = next(f.default for f in fields(self) if f.name == name)
            if getattr(self, name) != default:
                ctx.fail(f"{path}.{name} is only used with transport = "
                         f"{'rtu' if self.transport == 'tcp' else 'tcp'!r}, "
                         f"not with transport = {self.transport!r}")
        for name in other:
            if getattr(self, name) is not None:
                ctx.fail(f"{path}.{name} is only used with transport = "
                         f"{'rtu' if self.transport == 'tcp' else 'tcp'!r}, "
                         f"not with transport = {self.transport!r}")
        if not ctx.simulated:
            for name in need:
                if getattr(self, name) is None:
                    ctx.fail(f"{path}.{name} is required with transport = {self.transport!r}")
        if self.transport == "rtu" and not 1 <= self.unit_id <= 247:
            ctx.fail(f"{path}.unit_id = {self.unit_id} is out of range for Modbus RTU; "
                     f"allowed 1..247")


ACQUISITION_KINDS = ("modbus-daq", "scpi-scope")


@dataclass(frozen=True)
class AcquisitionConfig:
    """``[acquisition]``: the instrument the plans capture with (design §11, §12.2).

    ``modbus-daq`` (the default) is the ``[daq]``; ``scpi-scope`` an oscilloscope over VISA at
    ``resource`` (e.g. ``TCPIP::192.168.1.20::5025::SOCKET``) whose wiring, probe scales and
    dialect are the ``channel_map`` file (None: ``drivers/data/scope_channels.toml``;
    docs/acquisition.md). The dyno's speed reference stays on the ``[daq]``'s analog output."""

    kind: str = _key("modbus-daq", "str", choices=ACQUISITION_KINDS)
    resource: str | None = _key(None, "str")
    channel_map: Path | None = _key(None, "path")
    timeout_s: float = _key(10.0, "float", lo=0.1, hi=300.0)

    def _check(self, path: str, ctx: "_Context") -> None:
        if self.kind == "modbus-daq":
            for name in ("resource", "channel_map"):
                if getattr(self, name) is not None:
                    ctx.fail(f"{path}.{name} is only used with kind = \"scpi-scope\"")
        elif self.resource is None and not ctx.simulated:
            ctx.fail(f"{path}.resource is required with kind = \"scpi-scope\" on a real bench "
                     "(a VISA resource string, e.g. TCPIP::host::5025::SOCKET)")


@dataclass(frozen=True)
class TorqueConfig:
    """``[torque]``: the in-line torque transducer on a serial line, speaking ``dialect``."""

    serial_port: str | None = _key(None, "str", required=_REAL)
    #: None: the dialect family's published default (Magtrol 19200, Himmelstein 38400), filled
    #: in on load so the record states it; a rate the family does not publish is refused.
    baudrate: int | None = _key(None, "int", lo=300, hi=921_600)
    dialect: str = _key("magtrol", "str", choices=TORQUE_DIALECTS)
    full_scale_nm: float = _key(5.0, "float", lo=0.01, hi=10_000.0, required=_REAL)
    #: The transducer's -3 dB bandwidth (first-order response) from its data sheet; the ripple
    #: diagnosis corrects the order coefficients' phase and amplitude with it. None: not stated.
    bandwidth_hz: float | None = _key(None, "float", lo=1.0, hi=1e6)
    #: RMS noise of the torque reading, N·m (data sheet, or measured at rest); the validity
    #: floor derives the bench's resolvable ripple from it and the resolution (hil.validity).
    #: None: not stated (the floor stays two counts of the resolution).
    noise_rms_nm: float | None = _key(None, "float", lo=0.0, hi=1000.0)
    timeout_s: float = _key(1.0, "float", lo=0.01, hi=30.0)
    #: Magtrol DSP7000 only: the channel read (1 or 2: ``OD1``/``OD2``); None: a single-channel
    #: unit (DSP6001/6400: ``OD``).
    channel: int | None = _key(None, "int", choices=(1, 2))
    #: Himmelstein only: read torque with ``YC`` time stamps (an assumed layout, see
    #: drivers/transducer_dialects.py) instead of the documented ``DC`` query.
    timestamped: bool = _key(False, "bool")

    def dialect_options(self) -> dict:
        """The options of the dialect family (``ripple_hil_drivers.transducer_dialects``) this file states."""
        if self.dialect == "magtrol":
            return {"channel": self.channel}
        return {"timestamped": self.timestamped}

    def __post_init__(self) -> None:
        if self.baudrate is None:
            from ripple_hil_drivers.transducer_dialects import LINE_SETTINGS
            object.__setattr__(self, "baudrate", LINE_SETTINGS[self.dialect].default_baudrate)

    def _check(self, path: str, ctx: "_Context") -> None:
        from ripple_hil_drivers.transducer_dialects import LINE_SETTINGS
        if self.channel is not None and self.dialect != "magtrol":
            ctx.fail(f"{path}.channel is a Magtrol DSP7000 setting, not one of the "
                     f"{self.dialect} dialect")
        if self.timestamped and self.dialect != "himmelstein":
            ctx.fail(f"{path}.timestamped is a Himmelstein setting, not one of the "
                     f"{self.dialect} dialect")
        published = LINE_SETTINGS[self.dialect].baudrates
        if self.baudrate not in published:
            ctx.fail(f"{path}.baudrate = {self.baudrate} is not published for the "
                     f"{self.dialect} dialect; allowed: {', '.join(map(str, sorted(published)))}")


@dataclass(frozen=True)
class Limits:
    """``[limits]``: safety limits checked before any command is sent (design.md section 6)."""

    current_a: float = _key(60.0, "float", lo=0.1, hi=100.0, required=_REAL)
    speed_rpm: float = _key(3000.0, "float", lo=1.0, hi=3000.0, required=_REAL)
    torque_nm: float = _key(5.0, "float", lo=0.01, hi=10_000.0, required=_REAL)
    temperature_c: float = _key(100.0, "float", lo=20.0, hi=250.0, required=_REAL)


@dataclass(frozen=True)
class OperatingPoint:
    """``[operating_point]``: defaults for tests that do not set their own.

    ``current_a`` is the commanded peak phase-current amplitude; ``current_angle_deg`` is the
    angle φ by which the current lags the back EMF (paper eq. 4), in degrees at this user edge.
    """

    speed_rpm: float = _key(500.0, "float", lo=-3000.0, hi=3000.0)
    current_a: float = _key(20.0, "float", lo=0.0, hi=100.0)
    current_angle_deg: float = _key(0.0, "float", lo=-90.0, hi=90.0)

    @property
    def current_angle_rad(self) -> float:
        return math.radians(self.current_angle_deg)


@dataclass(frozen=True)
class InstrumentEntry:
    """One ``[[instrument]]``: what the certificate says about an instrument of the bench.

    ``range``, ``accuracy_class`` and ``resolution`` are written as on the data sheet, with
    units (``"±5 N*m"``, ``"0.1 % FS"``, ``"0.0005 N*m"``); :meth:`accuracy_pct_fs` and
    :meth:`resolution_nm` read the numbers out of them.
    """

    role: str = _key(None, "str", choices=INSTRUMENT_ROLES, required=_ALWAYS)
    model: str = _key(None, "str", required=_ALWAYS)
    serial_number: str = _key(None, "str", required=_ALWAYS)
    range: str | None = _key(None, "str")
    accuracy_class: str | None = _key(None, "str")
    resolution: str | None = _key(None, "str")
    calibration_date: date | None = _key(None, "date")
    calibration_due: date | None = _key(None, "date")

    def _check(self, path: str, ctx: "_Context") -> None:
        if self.accuracy_class is not None and self.role == "torque" \
                and self.accuracy_pct_fs() is None:
            ctx.fail(f"{path}.accuracy_class = {self.accuracy_class!r} is not a percentage of "
                     f"full scale; write it like \"0.1 % FS\"")
        if self.accuracy_class is not None and self.role in ("daq", "acquisition") \
                and self.gain_bound_pct() is None:
            ctx.fail(f"{path}.accuracy_class = {self.accuracy_class!r} is not a percentage of "
                     f"full scale or of reading; write it like \"0.05 % FS\" or \"0.1 % of "
                     f"reading\" (it bounds the channels' gain in the characterisation's U)")
        if self.calibration_date and self.calibration_due \
                and self.calibration_due < self.calibration_date:
            ctx.fail(f"{path}.calibration_due = {self.calibration_due} is before "
                     f"calibration_date = {self.calibration_date}")

    def accuracy_pct_fs(self) -> float | None:
        """The accuracy class as a percentage of full scale (``"0.1 % FS"``, ``"±0.1 %FSR"``),
        or None if not written that way."""
        match = re.fullmatch(r"\s*(?:class\s*)?(?:±|\+/-|\+-)?\s*(\d+(?:\.\d*)?|\.\d+)\s*%\s*"
                             r"(?:FSR?|F\.S\.|of full scale|full scale)?\s*",
                             self.accuracy_class or "", flags=re.IGNORECASE)
        return float(match.group(1)) if match else None

    def gain_bound_pct(self) -> float | None:
        """The largest gain error the accuracy class allows, % (None: not stated or not
        readable): a % FS class a bounds the error by a·FS over the range, so a pure gain error
        by a (at full scale); a % of reading class is a gain bound itself."""
        fs = self.accuracy_pct_fs()
        if fs is not None:
            return fs
        match = re.fullmatch(r"\s*(?:±|\+/-|\+-)?\s*(\d+(?:\.\d*)?|\.\d+)\s*%\s*"
                             r"(?:of reading|of rdg|rdg|reading)\s*",
                             self.accuracy_class or "", flags=re.IGNORECASE)
        return float(match.group(1)) if match else None

    def resolution_nm(self) -> float | None:
        """The resolution in N·m when written as a torque (``"0.001 N*m"``, ``"1 mN*m"``)."""
        match = re.fullmatch(r"\s*(\d+(?:\.\d*)?(?:e-?\d+)?|\.\d+)\s*(m?)N\s*[*·.\- ]?\s*m\s*",
                             self.resolution or "", flags=re.IGNORECASE)
        if not match:
            return None
        return float(match.group(1)) * (1e-3 if match.group(2) else 1.0)


@dataclass(frozen=True)
class LabInfo:
    """``[lab]``: who measured where, printed on the report."""

    name: str = _key("", "str")
    address: str = _key("", "str")
    operator: str = _key("", "str")
    # ISO/IEC 17025 §7.8.2 content of page 1 (each may be given on the command line instead)
    customer: str | None = _key(None, "str")
    authorizer: str | None = _key(None, "str")       # name of the person authorizing the report
    authorizer_function: str | None = _key(None, "str")
    item_received: date | None = _key(None, "date")  # date the item tested was received
    environment: str | None = _key(None, "str")      # e.g. "23 ± 2 °C, 45 % RH"; None: not recorded


@dataclass(frozen=True)
class RequirementsRef:
    """``[requirements]``: the user's requirements file ([[requirement]] tables, see
    :mod:`hil.requirements`), judged on every run of this bench unless ``--requirements`` is given."""

    file: Path | None = _key(None, "path")


@dataclass(frozen=True)
class ResultsRef:
    """``[results]``: where the results database indexes this bench's sealed records
    (:mod:`hil.results`): an SQLAlchemy URL, e.g. ``postgresql://user@host/ripple`` or
    ``sqlite:///records/results.sqlite``; ``"off"`` indexes nothing. None: the default (an SQLite
    file beside the records), unless ``--results-db`` or ``RIPPLE_HIL_RESULTS_DB`` says otherwise."""

    url: str | None = _key(None, "str")


_SECTIONS: dict[str, type] = {"drive": DriveConfig, "daq": DaqConfig, "torque": TorqueConfig,
                              "limits": Limits, "operating_point": OperatingPoint, "lab": LabInfo,
                              "requirements": RequirementsRef, "results": ResultsRef,
                              "acquisition": AcquisitionConfig}
_TOP_KEYS = ("simulated", "motor", *_SECTIONS, "instrument", "simulation")


# --------------------------------------------------------------------------- the bench

@dataclass(frozen=True)
class BenchConfig:
    """A validated bench file. Build it with :func:`load_bench` or :meth:`from_dict`."""

    simulated: bool
    motor: MotorParameters
    motor_identity: MotorIdentity
    drive: DriveConfig
    daq: DaqConfig
    torque: TorqueConfig
    limits: Limits
    operating_point: OperatingPoint
    instruments: tuple[InstrumentEntry, ...]
    lab: LabInfo
    requirements: RequirementsRef = field(default_factory=RequirementsRef)
    results: ResultsRef = field(default_factory=ResultsRef)
    acquisition: AcquisitionConfig = field(default_factory=AcquisitionConfig)
    source: str | None = field(default=None, compare=False)  # bench file path, or a label
    sha256: str | None = field(default=None, compare=False)  # of the file bytes (or canonical JSON)
    raw: dict = field(default_factory=dict, repr=False, compare=False)
    base_dir: Path | None = field(default=None, repr=False, compare=False)
    #: ``[simulation.defects]``: test-only defects of the simulated drive (``hil.sim.defects``
    #: field names -> values, validated); empty on a real bench and by default
    sim_defects: dict = field(default_factory=dict)
    #: ``[simulation.drive_identity]``: the CiA 301 identity (0x1018 ``vendor``, ``product``,
    #: ``revision``, ``serial``) the simulated drive reports; empty: its defaults
    sim_drive_identity: dict = field(default_factory=dict)
    #: ``[simulation.actual]``: the simulated bench's physics where it differs from the file
    #: (``hil.actual``: key -> value, validated); empty on a real bench and by default
    sim_actual: dict = field(default_factory=dict)
    #: ``[simulation] plant``: who computes the simulated instruments' samples (``hil.plants``)
    sim_plant: str = "ripple-hil"
    #: The ``[motor]`` the drive's PI current loop was designed from (Kp = L·ωc, Ki = R·ωc) when
    #: it is not :attr:`motor`: set by ``hil.characterisation.result.Characterisation.
    #: measured_config`` to the stated nameplate when the measured motor differs (the drive was
    #: configured from the nameplate); None: the motor's own (the models' pole-zero cancellation)
    loop_tuning: MotorParameters | None = field(default=None, repr=False)

    def model_point(self, speed_rpm: float, current_a: float, current_angle_rad: float = 0.0,
                    **options):
        """The models' ``hil.model.OperatingPoint`` on this bench: its motor and the motor its
        loop was tuned on (:attr:`loop_tuning`); ``options``: the point's other fields."""
        from hil.model import OperatingPoint

        return OperatingPoint(speed_rpm=speed_rpm, current_a=current_a,
                              current_angle_rad=current_angle_rad, motor=self.motor,
                              loop_tuning=self.loop_tuning, **options)

    @classmethod
    def from_dict(cls, d: dict, *, source: str | None = None, sha256: str | None = None,
                  base_dir: str | Path | None = None) -> "BenchConfig":
        """Validate a bench as a dict (the parsed TOML). Relative paths resolve from ``base_dir``.

        ``sha256`` defaults to the hash of the dict's canonical JSON (sorted keys).
        """
        if not isinstance(d, dict):
            raise InputError(f"{source or 'bench'}: a bench must be a table of sections, "
                             f"got {type(d).__name__}")
        ctx = _Context(source or "bench", Path(base_dir) if base_dir is not None else None)
        _reject_unknown(d.keys(), _TOP_KEYS, "", ctx)
        simulated = d.get("simulated", False)
        if not isinstance(simulated, bool):
            ctx.fail(f"simulated = {simulated!r} must be true or false")
        ctx.simulated = simulated
        sections = {name: _parse_section(section_cls, d.get(name, {}), name, ctx)
                    for name, section_cls in _SECTIONS.items()}
        motor, motor_identity = _parse_motor(d.get("motor", {}), ctx)
        instruments = _parse_instruments(d.get("instrument", []), ctx)
        sim_defects = _parse_simulation(d.get("simulation", {}), ctx)
        sim_identity = _parse_sim_identity(d.get("simulation", {}), ctx)
        from hil.actual import parse_actual
        sim_actual = parse_actual(d.get("simulation", {}).get("actual"), ctx)
        bench = cls(simulated=simulated, motor=motor, motor_identity=motor_identity,
                    instruments=instruments, source=source, raw=_plain(d),
                    sim_defects=sim_defects, sim_drive_identity=sim_identity, sim_actual=sim_actual,
                    sim_plant=_parse_plant(d.get("simulation", {}), ctx),
                    sha256=sha256 or hashlib.sha256(_canonical_json(d)).hexdigest(),
                    base_dir=ctx.base_dir, **sections)
        bench._check(ctx)
        plausibility.check(bench, ctx.fail)      # units and physics (hil/plausibility.py)
        return bench

    def _check(self, ctx: "_Context") -> None:
        op, lim = self.operating_point, self.limits
        if abs(op.speed_rpm) > lim.speed_rpm:
            ctx.fail(f"operating_point.speed_rpm = {op.speed_rpm} exceeds limits.speed_rpm = "
                     f"{lim.speed_rpm}; allowed -{lim.speed_rpm}..{lim.speed_rpm}")
        if op.current_a > lim.current_a:
            ctx.fail(f"operating_point.current_a = {op.current_a} exceeds limits.current_a = "
                     f"{lim.current_a}; allowed 0..{lim.current_a}")
        if not self.simulated and self.instrument("torque") is None:
            ctx.fail("instrument: a real bench needs an [[instrument]] with role = \"torque\" "
                     "(its accuracy class enters the uncertainty budget)")

    def instrument(self, role: str) -> InstrumentEntry | None:
        """The ``[[instrument]]`` entry with this role, or None."""
        return next((entry for entry in self.instruments if entry.role == role), None)

    def calibration_problems(self, today: date) -> list[str]:
        """Instruments whose calibration is past due (or dated in the future) or not stated.

        On a simulated bench, an instrument without calibration dates is not a problem (a
        simulated instrument has no certificate); stated dates are still checked.
        """
        problems = []
        for entry in self.instruments:
            name = f"{entry.role} {entry.model} s/n {entry.serial_number}"
            if entry.calibration_due is None or entry.calibration_date is None:
                if not self.simulated:
                    missing = [key for key in ("calibration_date", "calibration_due")
                               if getattr(entry, key) is None]
                    problems.append(f"{name}: {' and '.join(missing)} not stated")
            if entry.calibration_due is not None and entry.calibration_due < today:
                problems.append(f"{name}: calibration was due {entry.calibration_due.isoformat()}"
                                f" (today is {today.isoformat()})")
            if entry.calibration_date is not None and entry.calibration_date > today:
                problems.append(f"{name}: calibration_date {entry.calibration_date.isoformat()} "
                                f"is in the future (today is {today.isoformat()})")
        return problems

    def uncertainty_inputs(self) -> dict:
        """Type-B inputs of the torque chain, keyed as ``hil.analysis.InstrumentUncertainty``.

        ``transducer_accuracy_class_pct``: the torque transducer's accuracy class, % of its full
        scale (0 if not stated: no type-B term); ``transducer_full_scale_nm``: ``[torque]
        full_scale_nm``; ``daq_lsb_nm``: the DAQ's torque resolution if its ``resolution`` is
        written in N·m, else the transducer's, else None.
        """
        torque = self.instrument("torque")
        daq = self.instrument("daq")
        resolution = next((entry.resolution_nm() for entry in (daq, torque)
                           if entry is not None and entry.resolution_nm() is not None), None)
        accuracy = torque.accuracy_pct_fs() if torque else None
        return {"transducer_accuracy_class_pct": accuracy or 0.0,
                "transducer_full_scale_nm": self.torque.full_scale_nm,
                "daq_lsb_nm": resolution}

    def daq_gain_u_rel(self) -> float:
        """Relative standard uncertainty of the voltage and current channels' gain (type B),
        from the accuracy class of the ``[[instrument]]`` that acquires them — ``role = "daq"``,
        or ``role = "acquisition"`` on a bench whose ``[acquisition]`` is another instrument:
        its gain bound ``a`` (:meth:`InstrumentEntry.gain_bound_pct`), rectangular, a/100/√3.
        The class must cover the whole channel chain (probe or sensor and input). 0 where none
        is stated (the record's method says so)."""
        role = "daq" if self.acquisition.kind == "modbus-daq" else "acquisition"
        entry = self.instrument(role)
        bound = entry.gain_bound_pct() if entry is not None else None
        return (bound or 0.0) / 100.0 / math.sqrt(3.0)

    def instrument_uncertainty(self):
        """``hil.analysis.InstrumentUncertainty`` built from :meth:`uncertainty_inputs`."""
        from hil.analysis import InstrumentUncertainty  # analysis never imports config
        return InstrumentUncertainty(**self.uncertainty_inputs())

    def to_dict(self) -> dict:
        """The bench as validated, defaults filled in, JSON-safe; ``from_dict`` accepts it."""
        motor = {f.name: getattr(self.motor, f.name) for f in fields(MotorParameters)}
        motor.update(_section_to_dict(self.motor_identity))
        out: dict[str, Any] = {"simulated": self.simulated, "motor": motor}
        for name in _SECTIONS:
            out[name] = _section_to_dict(getattr(self, name))
        out["instrument"] = [_section_to_dict(entry) for entry in self.instruments]
        if self.sim_defects:
            out["simulation"] = {"defects": dict(self.sim_defects)}
        if self.sim_drive_identity:
            out.setdefault("simulation", {})["drive_identity"] = dict(self.sim_drive_identity)
        if self.sim_actual:
            out.setdefault("simulation", {})["actual"] = dict(self.sim_actual)
        if self.sim_plant != "ripple-hil":
            out.setdefault("simulation", {})["plant"] = self.sim_plant
        return out

    def with_overrides(self, changes: dict) -> "BenchConfig":
        """A new bench with ``changes`` merged into the file's tables and validated again.

        Example: ``bench.with_overrides({"daq": {"host": "127.0.0.1", "port": 5020}})``. The
        ``sha256`` stays that of the original file; ``raw`` shows the merged tables. It rebuilds
        from the file's tables: a bench as measured (``Characterisation.measured_config``) comes
        back as stated, without its measured values and ``loop_tuning``.
        """
        merged = _deep_merge(self.raw, changes)
        return BenchConfig.from_dict(merged, source=self.source, sha256=self.sha256,
                                     base_dir=self.base_dir)


def load_bench(path: str | Path) -> BenchConfig:
    """Read and validate a bench file; any problem raises InputError naming the key."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise InputError(f"bench file {str(path)!r} cannot be read: {exc.strerror}") from None
    try:
        table = tomllib.loads(data.decode("utf-8"))
    except UnicodeDecodeError:
        raise InputError(f"bench file {str(path)!r} is not UTF-8 text") from None
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"bench file {str(path)!r} is not valid TOML: {exc}") from None
    return BenchConfig.from_dict(table, source=str(path), sha256=hashlib.sha256(data).hexdigest(),
                                 base_dir=path.resolve().parent)


def example_bench_path(name: str = "sim-bench") -> Path:
    """Path of a bench file shipped in ``hil/examples`` (``sim-bench`` or ``real-bench``)."""
    path = Path(str(resources.files("hil") / "examples" / f"{name}.toml"))
    if not path.is_file():
        raise InputError(f"no shipped example bench {name!r}; "
                         f"there are {sorted(p.stem for p in path.parent.glob('*.toml'))}")
    return path


def default_sim_bench() -> BenchConfig:
    """The shipped simulated bench (``hil/examples/sim-bench.toml``)."""
    return load_bench(example_bench_path("sim-bench"))


# --------------------------------------------------------------------------- validation

class _Context:
    def __init__(self, source: str, base_dir: Path | None) -> None:
        self.source = source
        self.base_dir = base_dir
        self.simulated = False

    def fail(self, message: str) -> NoReturn:
        raise InputError(f"{self.source}: {message}")


def _specs(cls: type) -> list[tuple[dataclasses.Field, _Spec]]:
    return [(f, f.metadata["spec"]) for f in fields(cls)]


def _reject_unknown(keys, allowed, path: str, ctx: _Context) -> None:
    for key in keys:
        if key not in allowed:
            where = f"{path}.{key}" if path else str(key)
            close = difflib.get_close_matches(str(key), list(allowed), n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            ctx.fail(f"unknown key {where!r}{hint}; allowed keys"
                     f"{' in [' + path + ']' if path else ''}: {', '.join(allowed)}")


def _parse_section(cls: type, table: Any, path: str, ctx: _Context):
    if not isinstance(table, dict):
        ctx.fail(f"{path} must be a table ([{path}]), got {type(table).__name__}")
    specs = _specs(cls)
    _reject_unknown(table.keys(), [f.name for f, _ in specs], path, ctx)
    values = {}
    for f, spec in specs:
        key = f"{path}.{f.name}"
        value = table.get(f.name)
        if value is None:
            if spec.required == _ALWAYS or (spec.required == _REAL and not ctx.simulated):
                ctx.fail(f"{key} is required{'' if ctx.simulated else ' on a real bench'}"
                         f"{_allowed(spec)}")
            continue
        values[f.name] = _coerce(spec, value, key, ctx)
    obj = cls(**values)
    check = getattr(obj, "_check", None)
    if check is not None:
        check(path, ctx)
    return obj


def _coerce(spec: _Spec, value: Any, key: str, ctx: _Context) -> Any:
    kind = spec.kind
    if kind == "bool":
        if not isinstance(value, bool):
            ctx.fail(f"{key} = {value!r} must be true or false")
        return value
    if kind == "int" or (kind == "channel" and isinstance(value, int)):
        if isinstance(value, bool) or not isinstance(value, int):
            ctx.fail(f"{key} = {value!r} must be an integer{_allowed(spec)}")
    elif kind == "float":
        if isinstance(value, bool) or not isinstance(value, (int, float)) \
                or not math.isfinite(value):
            ctx.fail(f"{key} = {value!r} must be a finite number{_allowed(spec)}")
        value = float(value)
    elif kind in ("str", "path", "channel"):
        if not isinstance(value, str) or not value.strip():
            ctx.fail(f"{key} = {value!r} must be a non-empty string{_allowed(spec)}")
    elif kind == "date":
        value = _to_date(value, key, ctx)
    if spec.choices is not None and value not in spec.choices:
        ctx.fail(f"{key} = {value!r} is not allowed{_allowed(spec)}")
    if spec.lo is not None and not spec.lo <= value <= spec.hi:
        ctx.fail(f"{key} = {value!r} is out of range{_allowed(spec)}")
    if kind == "path":
        value = _resolve_path(value, key, ctx)
    return value


def _allowed(spec: _Spec) -> str:
    if spec.choices is not None:
        return "; allowed: " + ", ".join(repr(c) if isinstance(c, str) else str(c)
                                         for c in spec.choices)
    if spec.lo is not None:
        return f"; allowed {spec.lo:g}..{spec.hi:g}"
    return {"date": "; a date like 2026-03-31", "path": "; a file path"}.get(spec.kind, "")


def _to_date(value: Any, key: str, ctx: _Context) -> date:
    if isinstance(value, date) and not hasattr(value, "hour"):
        return value
    if isinstance(value, str):
        try:
            return date.fromisoformat(value)
        except ValueError:
            pass
    ctx.fail(f"{key} = {value!r} must be a date like 2026-03-31")


def _resolve_path(value: str, key: str, ctx: _Context) -> Path:
    path = Path(value).expanduser()
    if not path.is_absolute() and ctx.base_dir is not None:
        path = ctx.base_dir / path
    if not path.is_file():
        ctx.fail(f"{key} = {value!r}: no such file ({path}); relative paths are relative to "
                 f"the bench file's folder")
    return path


def _parse_motor(table: Any, ctx: _Context) -> tuple[MotorParameters, MotorIdentity]:
    if not isinstance(table, dict):
        ctx.fail(f"motor must be a table ([motor]), got {type(table).__name__}")
    identity_keys = tuple(f.name for f in fields(MotorIdentity))
    parameter_keys = tuple(f.name for f in fields(MotorParameters))
    _reject_unknown(table.keys(), parameter_keys + identity_keys, "motor", ctx)
    values = {}
    for f in fields(MotorParameters):
        if f.name in table:
            spec = (_Spec("str", choices=tuple(KE_DEFINITIONS)) if f.name == "ke_definition"
                    else _Spec("int" if isinstance(f.default, int) else "float"))
            values[f.name] = _coerce(spec, table[f.name], f"motor.{f.name}", ctx)
    try:
        motor = MotorParameters(**values)
    except ValueError as exc:
        ctx.fail(f"motor.{exc}")
    identity = _parse_section(MotorIdentity, {k: v for k, v in table.items() if k in identity_keys},
                              "motor", ctx)
    return motor, identity


def _parse_instruments(entries: Any, ctx: _Context) -> tuple[InstrumentEntry, ...]:
    if isinstance(entries, dict):
        entries = [entries]
    if not isinstance(entries, list):
        ctx.fail("instrument must be an array of tables ([[instrument]])")
    parsed = tuple(_parse_section(InstrumentEntry, entry, f"instrument[{i}]", ctx)
                   for i, entry in enumerate(entries))
    roles = [entry.role for entry in parsed]
    for role in set(roles):
        if roles.count(role) > 1:
            ctx.fail(f"instrument: role {role!r} appears {roles.count(role)} times; "
                     f"each role is one instrument")
    return parsed


def _parse_simulation(table: Any, ctx: _Context) -> dict:
    """``[simulation]``: ``defects`` (test-only, ``hil.sim.defects``) and ``actual``
    (``hil.actual``, parsed there), only when simulated; ``plant`` is read by
    :func:`_parse_plant`."""
    if not isinstance(table, dict):
        ctx.fail(f"simulation must be a table ([simulation]), got {type(table).__name__}")
    _reject_unknown(table.keys(), ("defects", "drive_identity", "actual", "plant"), "simulation", ctx)
    defects = table.get("defects", {})
    if not isinstance(defects, dict):
        ctx.fail(f"simulation.defects must be a table ([simulation.defects]), "
                 f"got {type(defects).__name__}")
    if not defects:
        return {}
    if not ctx.simulated:
        ctx.fail("simulation.defects are test-only defects of the simulated drive; they are "
                 "allowed only with simulated = true")
    from hil.sim.defects import DriveDefects   # only here: hil.sim loads the compiled engine

    try:
        return DriveDefects.from_dict(defects).to_dict()
    except InputError as exc:
        ctx.fail(str(exc))


#: ``[simulation.drive_identity]`` keys: the 0x1018 sub-index each sets (UNSIGNED32).
SIM_IDENTITY_KEYS = {"vendor": 1, "product": 2, "revision": 3, "serial": 4}


def _parse_sim_identity(table: dict, ctx: _Context) -> dict:
    """``[simulation.drive_identity]``: integers 0..2^32-1, only when simulated."""
    identity = table.get("drive_identity", {}) if isinstance(table, dict) else {}
    if not isinstance(identity, dict):
        ctx.fail("simulation.drive_identity must be a table ([simulation.drive_identity])")
    if identity and not ctx.simulated:
        ctx.fail("simulation.drive_identity is the simulated drive's; allowed only with "
                 "simulated = true")
    _reject_unknown(identity.keys(), tuple(SIM_IDENTITY_KEYS), "simulation.drive_identity", ctx)
    for key, value in identity.items():
        if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value < 2 ** 32:
            ctx.fail(f"simulation.drive_identity.{key} = {value!r} must be an integer in "
                     f"0..4294967295 (CiA 301 0x1018 is UNSIGNED32)")
    return dict(identity)


def _parse_plant(table: Any, ctx: _Context) -> str:
    """``[simulation] plant`` (``hil.plants.PLANTS``; default the ripple-hil twin), only when
    simulated. Called after :func:`_parse_simulation` has checked the table."""
    from hil.plants import DEFAULT_PLANT, PLANTS

    plant = table.get("plant", DEFAULT_PLANT)
    if plant not in PLANTS:
        ctx.fail(f"simulation.plant = {plant!r}; allowed {', '.join(map(repr, PLANTS))}")
    if plant != DEFAULT_PLANT and not ctx.simulated:
        ctx.fail(f"simulation.plant = {plant!r} names who computes a simulated bench's samples; "
                 f"allowed only with simulated = true")
    return plant


# --------------------------------------------------------------------------- helpers

def _section_to_dict(obj: Any) -> dict:
    return {f.name: _plain(getattr(obj, f.name)) for f in fields(obj)}


def _plain(value: Any) -> Any:
    """TOML values (dates, paths, nested tables) as JSON-safe values."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, (date, Path)):
        return value.isoformat() if isinstance(value, date) else str(value)
    if hasattr(value, "isoformat"):          # datetime.time
        return value.isoformat()
    return value


def _canonical_json(d: dict) -> bytes:
    return json.dumps(_plain(d), sort_keys=True, separators=(",", ":")).encode()


def _deep_merge(base: dict, changes: dict) -> dict:
    merged = dict(base)
    for key, value in changes.items():
        if isinstance(value, dict) and isinstance(merged.get(key), dict):
            merged[key] = _deep_merge(merged[key], value)
        else:
            merged[key] = value
    return merged
