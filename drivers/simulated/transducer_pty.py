"""Simulated serial torque transducer on a pseudo-terminal, backed by a ``hil.sim.DriveTwin``.

``os.openpty`` in raw mode; the simulator holds the master end, the driver opens ``sim.port``.
It answers the Magtrol or the Himmelstein messages as their manuals print them
(``ripple_hil_drivers.transducer_dialects`` lists the sources). Readings come from the twin: every data
request (Magtrol ``OD`` / ``OD1`` / ``OD2``, Himmelstein ``DC``, ``XC``, ``YC``) advances the twin
by ``1 / sample_rate_hz`` under its lock (asking it for ``torque_nm`` only) and reads its
latest torque (``status()["torque_nm"]``) and speed, so n readings cover n sample periods of
simulated time, in the same run the DAQ captures from. The instrument's own digital filter
(Himmelstein ``FL``) is a first-order low-pass at the selected cutoff, run at
``sample_rate_hz``; then tare, unit and the wire format's resolution apply.

Magtrol models (``magtrol_model``): ``"DSP6001"`` answers ``OD`` as ``SxxxxxTxxxxxR`` (speed
right-aligned in 5 characters, no leading zeros; torque in 5 characters with the decimal point
placed for the rated torque in the readout unit, e.g. ``S 1725T22.60R``), ``UR#``;
``"DSP7000"`` answers ``OD1`` / ``OD2`` as ``SxxxxxxTxxxxxR`` (6 speed characters; the transducer
is on channel 1, channel 2 reads zero), ``TS1``/``TS2``, ``TR1``/``TR2``; ``"6400"`` answers
``OD`` with the direction-input digit appended (``S 1725T22.60R1``). ``A`` replaces the direction
letter while the torque exceeds the rated torque (alarm). Unknown commands answer nothing (the
DSP6001/DSP7000 show "I/O ERROR" on the panel only). ``*IDN?`` answers
``MAGTROL,<model>,<serial>,REV 1.04`` (the manuals give no layout: our choice).
Himmelstein: ``DC`` answers the torque in display units with 6 significant digits (the manual's
``1234.56``), ``YC`` the assumed ``<8 hex ticks>,<4 hex counts>``; counts are 16-bit, 30000
counts = ``rated_torque_nm``.

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

from ripple_hil_drivers.transducer_dialects import (HIMMELSTEIN_FILTER_CUTOFF_HZ, HIMMELSTEIN_TICK_HZ,
                                         LBF_IN_NM, MAGTROL_UNIT_CODES, TORQUE_UNIT_NM,
                                         float_to_hex, hex_to_float)

log = logging.getLogger(__name__)

DEFAULT_GARBAGE = bytes([0x00, 0xFF, 0x13, 0x7F, 0xA5]) + b"~?%"
FULL_SCALE_COUNTS = 30000
MAGTROL_MODELS = ("DSP6001", "DSP7000", "6400")
MAGTROL_TORQUE_CHARACTERS = 5


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
            self.twin.advance(1.0 / self.sample_rate_hz, self.sample_rate_hz,
                              channels=("torque_nm",))
            status = self.twin.status()
        self.readings_served += 1
        return (self.filter.step(float(status["torque_nm"])), float(status["speed_rpm"]),
                float(status["time_s"]))

    @abstractmethod
    def handle(self, command: str) -> str | None:
        """The answer line to one command (None: the command has no answer)."""


def magtrol_torque_field(value: float, full_scale: float,
                         characters: int = MAGTROL_TORQUE_CHARACTERS) -> str:
    """The fixed-length torque field: ``characters`` wide, the decimal point placed so the full
    scale fits ([DSP6000] "the decimal point location depends on the ... torque range")."""
    integer_digits = max(1, len(str(int(abs(full_scale)))))
    decimals = max(0, characters - 1 - integer_digits)
    return f"{value:{characters}.{decimals}f}"


class _Magtrol(_Instrument):
    terminator = b"\r\n"

    def __init__(self, *args, model: str = "DSP6001", direction_input: bool = True) -> None:
        super().__init__(*args)
        if model not in MAGTROL_MODELS:
            raise ValueError(f"magtrol_model={model!r}; allowed {MAGTROL_MODELS}")
        self.model = model
        self.direction_input = direction_input
        self.unit = "oz.in"              # [6200] UR#: power-on default 0 = oz.in
        self.tare_on = False

    @property
    def data_commands(self) -> dict[str, int]:
        """Data command -> channel (0: the channel with nothing connected)."""
        return {"OD1": 1, "OD2": 0} if self.model == "DSP7000" else {"OD": 1}

    def _od(self, channel: int) -> str:
        torque, speed, _ = self.sample() if channel else (0.0, 0.0, 0.0)
        net = torque - (self.tare_nm if self.tare_on and channel else 0.0)
        full_scale = self.rated_torque_nm / TORQUE_UNIT_NM[self.unit]
        torque_text = magtrol_torque_field(net / TORQUE_UNIT_NM[self.unit], full_scale)
        direction = "A" if abs(torque) > self.rated_torque_nm else ("R" if speed >= 0 else "L")
        speed_width = 6 if self.model == "DSP7000" else 5
        digit = ("1" if speed >= 0 else "0") if self.direction_input else "0"
        tail = digit if self.model == "6400" else ""
        return f"S{round(abs(speed)):{speed_width}d}T{torque_text}{direction}{tail}"

    def handle(self, command: str) -> str | None:
        if command == "*IDN?":
            return f"MAGTROL,{self.model},{self.serial_number},REV 1.04"
        if command in self.data_commands:
            return self._od(self.data_commands[command])
        if self.model == "DSP7000" and command in ("TS1", "TR1", "TS2", "TR2"):
            if command == "TS1":
                self.tare_nm, self.tare_on = self.sample()[0], True
            elif command == "TR1":
                self.tare_on = False
        elif self.model != "DSP7000" and command.startswith("UR") and command[2:].isdigit():
            code = int(command[2:])                      # [6200]: out of range -> 0 (oz.in)
            self.unit = MAGTROL_UNIT_CODES[code if code < len(MAGTROL_UNIT_CODES) else 0]
        return None          # setting commands are silent; unknown ones only show on the panel


class _Himmelstein(_Instrument):
    terminator = b"\r"

    def __init__(self, *args) -> None:
        super().__init__(*args)
        self.scale_lbf_in = self.rated_torque_nm / LBF_IN_NM / FULL_SCALE_COUNTS
        self.display_scaling = 1.0             # display units per lbf-in (native unit)
        self.unit_name = "lbf-in"
        self.tare_counts = 0
        self.filter_code = 6                   # [MCRT]: factory default 10 Hz
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
                return f"{counts * self.scale_lbf_in * self.display_scaling:#.6g}".rstrip(".")
            if name == "XC":
                return f"{counts & 0xFFFF:04X}"
            ticks = round(time_s * HIMMELSTEIN_TICK_HZ) & 0xFFFFFFFF
            return f"{ticks:08X},{counts & 0xFFFF:04X}"
        if not arg:
            fixed = {"MD": "MCRT48200V", "SN": self.serial_number,
                     "VR": "Model MCRT48200V v1.2", "UN": self.unit_name,
                     "TV": str(self.tare_counts), "FL": f"{self.filter_code:02d}",
                     "DS": float_to_hex(self.display_scaling),
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
                 rated_torque_nm: float = 5.0, magtrol_model: str = "DSP6001") -> None:
        if dialect not in _DEVICES:
            raise ValueError(f"dialect={dialect!r}; allowed {sorted(_DEVICES)}")
        if not sample_rate_hz > 0:
            raise ValueError(f"sample_rate_hz={sample_rate_hz} must be > 0")
        self.dialect = dialect
        options = {"model": magtrol_model} if dialect == "magtrol" else {}
        self.instrument = _DEVICES[dialect](twin, float(sample_rate_hz), serial_number,
                                            rated_torque_nm, **options)
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
