"""Simulated serial torque transducer on a pseudo-terminal, backed by a ``hil.sim.DriveTwin``.

``os.openpty`` in raw mode; the simulator holds the master end, the driver opens ``sim.port``.
It answers the Magtrol or the Himmelstein dialect (``drivers.transducer_dialects`` documents
both). Readings come from the twin: every data request (Magtrol ``OD``, Himmelstein ``DC``,
``XC``, ``YC``) advances the twin by ``1 / sample_rate_hz`` under its lock and reads its latest
transducer torque (``status()["torque_nm"]``) and speed, so n readings cover n sample periods of
simulated time, in the same run the DAQ captures from. The instrument's own digital filter is a
first-order low-pass at the selected cutoff, run at ``sample_rate_hz``; then tare, unit and the
wire format's resolution apply (Magtrol: 4 decimals of the readout unit; Himmelstein: 16-bit
counts of ``rated_torque_nm / 30000`` and ``DC`` with 4 decimals).

A pty ignores the baud rate; with ``pace_baud`` every byte written or read costs 10 bits of line
time. Fault switches for tests: ``inject_garbage`` (bytes before the next answers),
``drop_next`` (swallow answers: the driver times out), ``fragment`` (answers written in pieces,
so the driver sees partial lines).
"""

from __future__ import annotations

import logging
import math
import os
import select
import threading
import time
import tty
from abc import ABC, abstractmethod

from drivers.transducer_dialects import (HIMMELSTEIN_FILTER_CUTOFF_HZ, HIMMELSTEIN_TICK_HZ,
                                         LBF_IN_NM, MAGTROL_FILTER_CUTOFF_HZ,
                                         MAGTROL_UNIT_CODES, TORQUE_UNIT_NM, float_to_hex,
                                         hex_to_float)

log = logging.getLogger(__name__)

DEFAULT_GARBAGE = bytes([0x00, 0xFF, 0x13, 0x7F, 0xA5]) + b"~?%"
FULL_SCALE_COUNTS = 30000


class _LowPass:
    """First-order low-pass y += a*(x - y), a = 1 - exp(-2*pi*fc/fs); None cutoff = pass."""

    def __init__(self, sample_rate_hz: float) -> None:
        self.sample_rate_hz = sample_rate_hz
        self.cutoff_hz: float | None = None
        self._y: float | None = None

    def set_cutoff(self, cutoff_hz: float | None) -> None:
        self.cutoff_hz = cutoff_hz
        self._y = None

    def step(self, x: float) -> float:
        if self.cutoff_hz is None or self._y is None:
            self._y = x
        else:
            a = 1.0 - math.exp(-2.0 * math.pi * self.cutoff_hz / self.sample_rate_hz)
            self._y += a * (x - self._y)
        return self._y


class _Instrument(ABC):
    """State shared by both dialects: the twin, the filter, the tare."""

    terminator = b"\r\n"

    def __init__(self, twin, sample_rate_hz: float, serial_number: str,
                 rated_torque_nm: float) -> None:
        self.twin = twin
        self.sample_rate_hz = sample_rate_hz
        self.serial_number = serial_number
        self.rated_torque_nm = rated_torque_nm
        self.filter = _LowPass(sample_rate_hz)
        self.tare_nm = 0.0
        self.readings_served = 0

    def sample(self) -> tuple[float, float, float]:
        """Advance the twin one sample period: (filtered torque N*m, speed rpm, time s)."""
        with self.twin.lock:
            self.twin.advance(1.0 / self.sample_rate_hz, self.sample_rate_hz)
            status = self.twin.status()
        self.readings_served += 1
        return (self.filter.step(float(status["torque_nm"])), float(status["speed_rpm"]),
                float(status["time_s"]))

    @abstractmethod
    def handle(self, command: str) -> str | None:
        """The answer line to one command (None: the command has no answer)."""


class _Magtrol(_Instrument):
    terminator = b"\r\n"

    def __init__(self, *args) -> None:
        super().__init__(*args)
        self.unit = "N.m"
        self.tare_on = False
        self.filter.set_cutoff(MAGTROL_FILTER_CUTOFF_HZ[0])

    def handle(self, command: str) -> str | None:
        if command == "*IDN?":
            return f"MAGTROL,DSP7000,{self.serial_number},REV 1.04"
        if command == "OD":
            torque, speed, _ = self.sample()
            net = torque - (self.tare_nm if self.tare_on else 0.0)
            direction = "A" if abs(torque) > self.rated_torque_nm else (
                "R" if speed >= 0 else "L")
            return f"S{round(abs(speed))}T{net / TORQUE_UNIT_NM[self.unit]:.4f}{direction}"
        if command == "TS1":
            self.tare_nm, self.tare_on = self.sample()[0], True
        elif command == "TR1":
            self.tare_on = False
        elif command.startswith("UR") and command[2:].isdigit():
            code = int(command[2:])
            if code < len(MAGTROL_UNIT_CODES):
                self.unit = MAGTROL_UNIT_CODES[code]
        elif command.startswith("TF") and command[2:].isdigit():
            code = int(command[2:])
            if code in MAGTROL_FILTER_CUTOFF_HZ:
                self.filter.set_cutoff(MAGTROL_FILTER_CUTOFF_HZ[code])
        return None          # setting commands are silent; unknown ones only beep on the panel


class _Himmelstein(_Instrument):
    terminator = b"\r"

    def __init__(self, *args) -> None:
        super().__init__(*args)
        self.scale_lbf_in = self.rated_torque_nm / LBF_IN_NM / FULL_SCALE_COUNTS
        self.display_scaling = 1.0             # display units per lbf-in (native unit)
        self.unit_name = "lbf-in"
        self.tare_counts = 0
        self.filter_code = 2
        self.filter.set_cutoff(HIMMELSTEIN_FILTER_CUTOFF_HZ[self.filter_code])

    def _counts(self, torque_nm: float) -> int:
        counts = round(torque_nm / LBF_IN_NM / self.scale_lbf_in)
        return max(-32768, min(32767, counts))

    def handle(self, command: str) -> str | None:
        name, arg = command[:2], command[2:]
        if name in ("DC", "XC", "YC") and not arg:
            torque, _, time_s = self.sample()
            counts = max(-32768, min(32767, self._counts(torque) - self.tare_counts))
            if name == "DC":
                return f"{counts * self.scale_lbf_in * self.display_scaling:.4f}"
            if name == "XC":
                return f"{counts & 0xFFFF:04X}"
            ticks = round(time_s * HIMMELSTEIN_TICK_HZ) & 0xFFFFFFFF
            return f"{ticks:08X},{counts & 0xFFFF:04X}"
        if not arg:
            fixed = {"MD": "MCRT48200V", "SN": self.serial_number, "VR": "v1.2",
                     "UN": self.unit_name, "TV": str(self.tare_counts),
                     "FL": f"{self.filter_code:02d}", "DS": float_to_hex(self.display_scaling),
                     "SC": float_to_hex(self.scale_lbf_in) * 2}
            if name in fixed:
                return fixed[name]
            if name == "TT":
                self.tare_counts = self._counts(self.sample()[0])
                return "OK"
        elif name == "FL":
            if not arg.isdigit() or int(arg) not in HIMMELSTEIN_FILTER_CUTOFF_HZ:
                return "!BadArg"
            self.filter_code = int(arg)
            self.filter.set_cutoff(HIMMELSTEIN_FILTER_CUTOFF_HZ[self.filter_code])
            return "OK"
        elif name == "UN":
            self.unit_name = arg
            return "OK"
        elif name == "DS":
            try:
                value = hex_to_float(arg)
            except ValueError:
                return "!BadArg"
            if not (math.isfinite(value) and value > 0):
                return "!BadArg"
            self.display_scaling = value
            return "OK"
        return f"!{name}"


_DEVICES = {"magtrol": _Magtrol, "himmelstein": _Himmelstein}


class SimulatedTransducer:
    """A torque transducer on a pty, answering one dialect from the twin's torque."""

    def __init__(self, twin, dialect: str = "magtrol", sample_rate_hz: float = 1000.0,
                 pace_baud: int | None = None, *, serial_number: str = "SIM-TQ-0001",
                 rated_torque_nm: float = 5.0) -> None:
        if dialect not in _DEVICES:
            raise ValueError(f"dialect={dialect!r}; allowed {sorted(_DEVICES)}")
        if not sample_rate_hz > 0:
            raise ValueError(f"sample_rate_hz={sample_rate_hz} must be > 0")
        self.dialect = dialect
        self.instrument = _DEVICES[dialect](twin, float(sample_rate_hz), serial_number,
                                            rated_torque_nm)
        self.pace_baud = pace_baud
        self.fragment = False
        self._garbage: list[bytes] = []
        self._drop = 0
        self._switch_lock = threading.Lock()
        self._master = self._slave = None
        self._stop_r = self._stop_w = None
        self._thread: threading.Thread | None = None
        self._port: str | None = None

    # ------------------------------------------------------------------ lifecycle
    def start(self) -> "SimulatedTransducer":
        self._master, self._slave = os.openpty()
        tty.setraw(self._master)
        tty.setraw(self._slave)
        self._port = os.ttyname(self._slave)
        self._stop_r, self._stop_w = os.pipe()
        self._thread = threading.Thread(target=self._run, daemon=True,
                                        name=f"sim-transducer-{self.dialect}")
        self._thread.start()
        return self

    def stop(self) -> None:
        if self._thread is None:
            return
        os.write(self._stop_w, b"x")
        self._thread.join(5.0)
        for fd in (self._master, self._slave, self._stop_r, self._stop_w):
            try:
                os.close(fd)
            except OSError:
                pass
        self._thread = None

    def __enter__(self) -> "SimulatedTransducer":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()

    @property
    def port(self) -> str:
        if self._port is None:
            raise RuntimeError("simulated transducer is not started")
        return self._port

    # ------------------------------------------------------------------ fault switches
    def inject_garbage(self, data: bytes = DEFAULT_GARBAGE, responses: int = 1) -> None:
        """Write ``data`` before each of the next ``responses`` answers."""
        with self._switch_lock:
            self._garbage += [bytes(data)] * responses

    def drop_next(self, responses: int = 1) -> None:
        """Swallow the next ``responses`` answers (the driver sees silence)."""
        with self._switch_lock:
            self._drop += responses

    # ------------------------------------------------------------------ serving
    def _run(self) -> None:
        pending = bytearray()
        while True:
            try:
                ready, _, _ = select.select([self._master, self._stop_r], [], [], 1.0)
            except (OSError, ValueError):
                return                     # descriptors closed under us: stopping
            if self._stop_r in ready:
                return
            if self._master not in ready:
                continue
            try:
                data = os.read(self._master, 4096)
            except OSError:
                time.sleep(0.01)           # no client has the slave open right now
                continue
            self._pace(len(data))
            pending += data
            while True:
                cut = min((i for i in (pending.find(b"\r"), pending.find(b"\n")) if i >= 0),
                          default=-1)
                if cut < 0:
                    break
                command = pending[:cut].decode("ascii", errors="replace").strip()
                del pending[:cut + 1]
                if command:
                    self._answer(command)

    def _answer(self, command: str) -> None:
        try:
            answer = self.instrument.handle(command)
        except Exception:  # noqa: BLE001 - a simulator fault must not kill the port thread
            log.exception("simulated transducer failed on %r", command)
            answer = "!Unknown" if self.dialect == "himmelstein" else None
        if answer is None:
            return
        with self._switch_lock:
            if self._drop:
                self._drop -= 1
                return
            prefix = self._garbage.pop(0) if self._garbage else b""
        payload = prefix + answer.encode("ascii") + self.instrument.terminator
        pieces = [payload[i:i + 3] for i in range(0, len(payload), 3)] if self.fragment \
            else [payload]
        for piece in pieces:
            self._pace(len(piece))
            os.write(self._master, piece)
            if self.fragment:
                time.sleep(0.002)

    def _pace(self, n_bytes: int) -> None:
        if self.pace_baud:
            time.sleep(n_bytes * 10.0 / self.pace_baud)
