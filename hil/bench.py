"""The bench: the drive, DAQ and torque transducer composed, with the limits and the safety guard.

Safety (design.md §6): limits from the bench file are checked before any command is sent, and every
measurement runs inside :meth:`Bench.guard`. On *any* exit path out of a guarded step — failure,
exception, timeout, lost heartbeat, EMCY, a limit breach seen in the data, Ctrl-C — the bench is
brought to a safe state: drive quick stop → switch-on-disabled, every injection restored to its
default (verified by read-back), DAQ disarmed, dyno speed reference zero.
"""

from __future__ import annotations

import contextlib
import logging
from dataclasses import dataclass, field

import numpy as np

from ripple_hil_drivers.errors import InstrumentError, LimitError
from hil.capture import Capture
from hil.config import BenchConfig
from hil.errors import HilError, InputError

logger = logging.getLogger(__name__)


#: Exit code of ``hil run`` / ``pytest`` when the bench could not be opened (nothing was run).
EXIT_BENCH_NOT_OPENED = 6
#: Exit code when the bench was lost mid-run (the remaining tests were not run).
EXIT_BENCH_LOST = 7



#: Window over which the captured speed is taken, s: the angle is a count (7200 per revolution on
#: the simulated drive), so sample to sample at ~190 kS/s a 2475 rpm rotor moves 1-2 counts and
#: the difference read 1584 or 3168-3329 rpm (a false trip of a 3000 rpm limit); over 1 ms one
#: count is ≈ 8 rpm, and a dyno cannot change speed within it.
SPEED_WINDOW_S = 1e-3


def windowed_speed_rpm(time_s, angle_rad) -> np.ndarray:
    """Mechanical speed, rpm, from a sampled (quantised) angle: the angle's change over
    :data:`SPEED_WINDOW_S` (at least one sample step) divided by the elapsed time."""
    time_s = np.asarray(time_s, dtype=float)
    angle = np.unwrap(np.asarray(angle_rad, dtype=float))
    step_s = float(np.median(np.diff(time_s)))
    lag = max(1, min(len(time_s) - 1, int(np.ceil(SPEED_WINDOW_S / step_s)))) if step_s > 0 else 1
    return (angle[lag:] - angle[:-lag]) / (time_s[lag:] - time_s[:-lag]) * 60.0 / (2.0 * np.pi)

class BenchOpenError(HilError):
    """The bench could not be opened: which instrument, what was tried, why it failed."""

    def __init__(self, instrument: str, tried: str, reason: str) -> None:
        self.instrument = instrument
        self.tried = tried
        self.reason = reason
        super().__init__(f"{instrument}: {tried}: {reason}")


class SafeStateError(HilError):
    """One or more steps of bringing the bench to a safe state failed (listed in ``failures``)."""

    def __init__(self, failures: list[str]) -> None:
        self.failures = failures
        super().__init__("could not bring the bench to a safe state: " + "; ".join(failures))


@dataclass
class SafeStateReport:
    """What :meth:`Bench.make_safe` did, step by step (for the record)."""

    reason: str
    steps: list[str] = field(default_factory=list)
    failures: list[str] = field(default_factory=list)

    def to_dict(self) -> dict:
        return {"reason": self.reason, "steps": self.steps, "failures": self.failures}


class Bench:
    """A connected bench. Build it with :meth:`open`; close it with :meth:`close` (or ``with``).

    ``simulated`` is the :class:`hil.simbench.SimulatedBench` behind a simulated bench (None on a
    real one); the drivers do not know the difference.
    """

    def __init__(self, config: BenchConfig, drive, daq, torque, simulated=None,
                 acquisition=None) -> None:
        self.config = config
        self.drive = drive
        self.daq = daq
        self.torque = torque
        #: the instrument the plans capture with (hil.acquisition.Acquisition): the DAQ, or
        #: the oscilloscope of [acquisition]; the dyno stays on the DAQ's analog output
        self.acquisition = acquisition if acquisition is not None else daq
        self.simulated = simulated
        self.safe_state_reports: list[SafeStateReport] = []
        #: the angle reference the self-check measured (hil.selfcheck.emf_angle_reference), as
        #: capture meta keys; every later capture of the run records it (hil.measurement)
        self.angle_reference_meta: dict = {}

    # ------------------------------------------------------------------ lifecycle
    @classmethod
    def open(cls, config: BenchConfig, *, seed: int = 0,
             drive_identity_check=None) -> "Bench":
        """Start the simulated instruments if needed, then connect the drivers.

        Order (issue 11 item 5): the DAQ and the torque transducer are connected and identified
        first; only then is the drive connected (its first CAN write). A simulated bench file
        without addresses (the shipped one) starts its instruments in this process; one with
        addresses (written by ``hil sim-bench``) connects to them. If anything fails part-way,
        everything opened so far is closed again and :class:`BenchOpenError` names the
        instrument, what was tried and why it failed. ``drive_identity_check(identity)`` is
        called with the drive's CiA 301 identity before anything is written to it (``hil.dut``);
        an :class:`~hil.errors.InputError` it raises passes through unwrapped.
        """
        simulated = None
        opened: list = []
        identities: dict[str, dict] = {}
        try:
            if config.simulated and not has_addresses(config):
                from hil.simbench import SimulatedBench

                simulated = SimulatedBench(config, seed=seed)
                config = _opening("simulated bench", "start the simulated instruments",
                                  simulated.start)
            for role, make in (("daq", _make_daq), ("acquisition", _make_scope),
                               ("torque", _make_torque), ("drive", _make_drive)):
                if role == "acquisition" and config.acquisition.kind == "modbus-daq":
                    continue
                instrument = _opening(role, _tried(role, config), lambda: make(config))
                if role == "drive" and drive_identity_check is not None:
                    instrument.identity_check = drive_identity_check
                _opening(role, _tried(role, config), instrument.connect)
                opened.append(instrument)
                identities[role] = _opening(role, f"identify ({_tried(role, config)})",
                                            instrument.identity)
        except BaseException:
            for instrument in reversed(opened):
                with contextlib.suppress(Exception):
                    instrument.close()
            if simulated is not None:
                simulated.stop()
            raise
        daq, *scope, torque, drive = opened
        bench = cls(config, drive, daq, torque, simulated, scope[0] if scope else None)
        bench._identities = identities
        bench.make_safe("bench opened")
        return bench

    def close(self) -> None:
        """Leave the drive safe, then close the drivers and stop any simulated instruments."""
        try:
            self.make_safe("bench closed", raise_on_failure=False)
        finally:
            for instrument in (self.torque, self.daq, self.drive) + self._scope():
                with contextlib.suppress(Exception):
                    instrument.close()
            if self.simulated is not None:
                self.simulated.stop()

    def __enter__(self) -> "Bench":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _scope(self) -> tuple:
        """The acquisition instrument when it is not the DAQ (an oscilloscope), else ()."""
        return () if self.acquisition is self.daq else (self.acquisition,)

    def location(self) -> dict:
        """Where the instruments are, for the record: ``kind`` is "simulated-in-process" (started
        by :meth:`open` in this process), "simulated-separate-process" (a simulated bench file
        with addresses, e.g. written by ``hil sim-bench``) or "real"; ``addresses`` says what
        each driver connected to."""
        if self.simulated is not None:
            kind = "simulated-in-process"
        else:
            kind = "simulated-separate-process" if self.config.simulated else "real"
        roles = ("drive", "daq", "torque") + (("acquisition",) if self._scope() else ())
        return {"kind": kind, "addresses": {role: _address(role, self.config) for role in roles}}

    def identities(self) -> list[dict]:
        """Each instrument's identity as it answered when the bench was opened (for the record's
        instrument table); queried again if the bench was built without :meth:`open`."""
        rows = []
        roles = (("drive", self.drive), ("daq", self.daq), ("torque", self.torque)) + \
            tuple(("acquisition", scope) for scope in self._scope())
        for role, instrument in roles:
            known = getattr(self, "_identities", {}).get(role)
            try:
                rows.append({"role": role, **(known if known is not None
                                               else instrument.identity())})
            except InstrumentError as exc:
                rows.append({"role": role, "error": str(exc)})
        return rows

    def probe(self) -> list[InstrumentError]:
        """Ask each instrument one cheap question; the errors of those that do not answer.

        Used after an instrument error to tell a lost bench (a transport gone: the session must
        stop) from a one-off fault (the next test may still run)."""
        failures = []
        for role, ask in (("drive", lambda: self.drive.statusword),
                          ("daq", self.daq.status), ("torque", self.torque.identity),
                          *(("acquisition", scope.status) for scope in self._scope())):
            try:
                ask()
            except InstrumentError as exc:
                failures.append(exc)
            except Exception as exc:  # noqa: BLE001 - an untyped driver error is a loss too
                failures.append(InstrumentError(role, "probe", f"{type(exc).__name__}: {exc}"))
        return failures

    # ------------------------------------------------------------------ limits
    def check_command(self, *, current_a: float, speed_rpm: float) -> None:
        """Refuse an operating point outside the bench's limits, before anything is sent."""
        limits = self.config.limits
        if not 0.0 <= current_a <= limits.current_a:
            raise LimitError("drive", "check current command",
                             f"current_a={current_a:g} A is outside 0..{limits.current_a:g} A "
                             f"(bench limits.current_a)")
        if abs(speed_rpm) > limits.speed_rpm:
            raise LimitError("daq", "check dyno speed reference",
                             f"speed_rpm={speed_rpm:g} is outside ±{limits.speed_rpm:g} rpm "
                             f"(bench limits.speed_rpm)")

    def check_capture(self, capture: Capture) -> None:
        """Raise LimitError if the captured data shows a current, torque, speed or temperature
        past its limit. Speed comes from the rotor angle; temperature is checked when the DAQ
        captures a ``temperature_c`` channel (the shipped register map has none)."""
        limits = self.config.limits
        peaks = {name: float(np.max(np.abs(capture[name])))
                 for name in ("ia_a", "ib_a", "torque_nm", "temperature_c") if name in capture}
        if "rotor_angle_mech_rad" in capture and len(capture) > 1:
            peaks["speed_rpm"] = float(np.max(np.abs(windowed_speed_rpm(
                capture["time_s"], capture["rotor_angle_mech_rad"]))))
        checks = (("ia_a", limits.current_a, "A", "current_a"),
                  ("ib_a", limits.current_a, "A", "current_a"),
                  ("torque_nm", limits.torque_nm, "N·m", "torque_nm"),
                  ("speed_rpm", limits.speed_rpm, "rpm", "speed_rpm"),
                  ("temperature_c", limits.temperature_c, "°C", "temperature_c"))
        for name, limit, unit, key in checks:
            if name in peaks and peaks[name] > limit:
                raise LimitError("daq", "check captured data",
                                 f"|{name}| reached {peaks[name]:.4g} {unit} > limits.{key} = "
                                 f"{limit:g} {unit}")

    # ------------------------------------------------------------------ safety
    def check_health(self, *, synchronise: bool = False) -> None:
        """Raise if the drive reported an EMCY / fault or its heartbeat stopped; ``synchronise``
        waits for every report the drive sent before the check (one SDO round trip)."""
        self.drive.check_health(synchronise=synchronise)

    @contextlib.contextmanager
    def guard(self, step: str):
        """Run a step; on any exception (Ctrl-C included) make the bench safe, then re-raise."""
        try:
            yield self
        except BaseException as exc:
            reason = f"{step}: {type(exc).__name__}: {exc}"
            logger.warning("safety guard: %s", reason)
            try:
                self.make_safe(reason, raise_on_failure=False)
            except BaseException:  # noqa: BLE001 - never mask the original error
                logger.exception("safety guard: making the bench safe failed")
            raise

    def make_safe(self, reason: str, *, raise_on_failure: bool = True) -> SafeStateReport:
        """Quick stop → switch-on-disabled, restore injections (read back), disarm DAQ, dyno 0.

        Every step is tried even if an earlier one fails; failures are collected in the report
        and raised together as :class:`SafeStateError` unless ``raise_on_failure`` is False.
        """
        report = SafeStateReport(reason)
        steps = (
            ("drive quick stop", lambda: self.drive.quick_stop()),
            ("drive disable (switch-on-disabled)", lambda: self.drive.disable()),
            ("drive current command 0 A", lambda: self.drive.set_current_command_a(0.0)),
            ("restore injection defaults (verified)", self.drive.restore_injection_defaults),
            ("DAQ disarm", self.daq.disarm),
            *(("oscilloscope stop", scope.disarm) for scope in self._scope()),
            ("dyno speed reference 0 rpm", lambda: self.daq.set_dyno_speed_rpm(0.0)),
        )
        interrupted = first_error = None
        for name, action in steps:
            try:
                action()
                report.steps.append(name)
            except KeyboardInterrupt as exc:   # a second Ctrl-C must not skip the other steps
                interrupted = exc
                report.failures.append(f"{name}: interrupted by Ctrl-C")
            except Exception as exc:  # noqa: BLE001 - keep going: the next step may still help
                first_error = first_error or exc
                report.failures.append(f"{name}: {exc}")
        self.safe_state_reports.append(report)
        if interrupted is not None:
            raise interrupted
        if report.failures:
            logger.error("safe state incomplete: %s", report.failures)
            if raise_on_failure:
                # the first step's own error as the cause: a lost transport stays typed, so
                # the run reports the bench lost in one line (it read as a drive failure)
                raise SafeStateError(report.failures) from first_error
        return report


def _opening(role: str, tried: str, step):
    """Run one step of opening the bench; any failure becomes one :class:`BenchOpenError`."""
    try:
        return step()
    except (BenchOpenError, InputError):      # InputError: the user's (hil.dut), not the bench's
        raise
    except InstrumentError as exc:
        raise BenchOpenError(role, tried, exc.detail) from exc
    except Exception as exc:  # noqa: BLE001 - e.g. a CAN interface whose library is missing
        raise BenchOpenError(role, tried, f"{type(exc).__name__}: {exc}") from exc


def _tried(role: str, config: BenchConfig) -> str:
    """What connecting ``role`` tries, in the bench file's words."""
    return ("open " if role == "torque" else "connect ") + _address(role, config)


def _address(role: str, config: BenchConfig) -> str:
    """Where the bench file puts ``role``: bus and node, host and port, or serial port."""
    if role == "drive":
        drive = config.drive
        return (f"CANopen node {drive.node_id} on {drive.interface} channel {drive.channel!r} "
                f"at {drive.bitrate} bit/s")
    if role == "acquisition":
        return f"{config.acquisition.kind} at {config.acquisition.resource}"
    if role == "daq":
        daq = config.daq
        if daq.transport == "rtu":
            return f"Modbus RTU on {daq.serial_port} at {daq.baudrate or 115200} baud"
        return f"Modbus TCP {daq.host}:{daq.port} unit {daq.unit_id}"
    torque = config.torque
    return (f"serial port {torque.serial_port} at {torque.baudrate} baud "
            f"({torque.dialect} dialect)")


def has_addresses(config: BenchConfig) -> bool:
    """True if the bench file says where its drive, DAQ and transducer are."""
    daq_at = config.daq.serial_port if config.daq.transport == "rtu" else config.daq.port
    scope_at = config.acquisition.kind == "modbus-daq" or config.acquisition.resource
    return bool(config.drive.channel and daq_at and config.torque.serial_port and scope_at)


def _make_drive(config: BenchConfig):
    from ripple_hil_drivers.canopen_transport import CanBusSettings
    from ripple_hil_drivers.cia402 import Cia402Drive

    drive = config.drive
    return Cia402Drive(CanBusSettings(interface=drive.interface, channel=drive.channel,
                                      bitrate=drive.bitrate),
                       node_id=drive.node_id, eds_path=drive.eds, profile=drive.profile,
                       sdo_timeout_s=drive.sdo_timeout_s,
                       heartbeat_timeout_s=drive.heartbeat_timeout_s, instrument_name="drive")


def _make_daq(config: BenchConfig):
    from ripple_hil_drivers.modbus_daq import (ModbusDaq, ModbusRtuSettings, ModbusTcpSettings,
                                    TransferOptions)

    daq = config.daq
    transfer = TransferOptions()
    if daq.transport == "rtu":
        settings = ModbusRtuSettings(port=daq.serial_port, baudrate=daq.baudrate or 115200,
                                     parity=daq.parity, stopbits=daq.stopbits)
    else:
        settings = ModbusTcpSettings(host=daq.host, port=daq.port)
        transfer = TransferOptions(in_flight=daq.requests_in_flight)
    return ModbusDaq(settings, unit_id=daq.unit_id, register_map=daq.register_map,
                     timeout_s=daq.timeout_s, instrument_name="daq", transfer=transfer)


def _make_scope(config: BenchConfig):
    from hil.acquisition import make_acquisition

    return make_acquisition(config, None)


def _make_torque(config: BenchConfig):
    from ripple_hil_drivers.torque_transducer import SerialSettings, TorqueTransducer

    torque = config.torque
    return TorqueTransducer(SerialSettings(port=torque.serial_port, baudrate=torque.baudrate),
                            dialect=torque.dialect, timeout_s=torque.timeout_s,
                            instrument_name="torque", dialect_options=torque.dialect_options())
