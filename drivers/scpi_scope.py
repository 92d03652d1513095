"""An oscilloscope as the acquisition instrument: SCPI over VISA (pyvisa with pyvisa-py).

The second implementation of the acquisition contract (``hil.acquisition.Acquisition``; the
Modbus DAQ is the first). Dialect: Keysight InfiniiVision, as its programmer's guide documents it
(``:WAVeform`` subsystem): ``:DIGitize`` a single shot of the wired channels, then per channel
``:WAVeform:SOURce``, ``:WAVeform:FORMat WORD`` (MSB first, unsigned), ``:WAVeform:PREamble?``
(format, type, points, count, xincrement, xorigin, xreference, yincrement, yorigin, yreference)
and ``:WAVeform:DATA?`` (an IEEE 488.2 definite-length block ``#8NNNNNNNN…``); volts =
(code − yreference)·yincrement + yorigin, time = (i − xreference)·xincrement. In WORD data,
0x0000 is a hole (not acquired), 0x0001 clipped low, 0xFFFF clipped high. Settings are
properties mapped to commands (PyMeasure's style, without PyMeasure).

The channel map (``drivers/data/scope_channels.toml``, :func:`load_channel_map`) says what each
input carries, its probe scale to SI and the vertical setup. A capture: stop, timebase (range =
duration, reference LEFT, position = settle_s: the first sample comes settle_s after the
trigger), RAW points = duration·rate, vertical setup, ``:DIGitize``, ``*OPC?``, read and check
(points, one x axis, the rate asked, no holes, the error queue empty), convert to SI. A capture
that is not what was asked raises :class:`ScopeCaptureError` carrying the data as received; a
clipped channel raises ``ChannelClippedError``, a ``LimitError`` (the capture would understate the ripple).
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ripple_hil_drivers.errors import (ChannelClippedError, DeviceFault, InstrumentError,
                                       InstrumentTimeout, ProtocolError, TransportLost,
                                       transport_reason)
from hil.capture import Capture
from hil.errors import InputError

DEFAULT_CHANNEL_MAP = Path(__file__).parent / "data" / "scope_channels.toml"
DIALECTS = ("keysight-infiniivision",)
#: WORD codes with a meaning of their own (InfiniiVision :WAVeform:DATA?).
HOLE, CLIPPED_LOW, CLIPPED_HIGH = 0x0000, 0x0001, 0xFFFF
PREAMBLE_FIELDS = ("format", "type", "points", "count", "xincrement", "xorigin", "xreference",
                   "yincrement", "yorigin", "yreference")
WORD_FORMAT = 1


@dataclass(frozen=True)
class ScopeChannel:
    """One scope input: the capture channel it carries and how its volts become SI."""

    name: str
    source: str                  # dialect mnemonic, e.g. "CHANnel1"
    si_per_volt: float = 1.0     # SI units per volt at the scope input
    volts_per_div: float = 1.0
    offset_v: float = 0.0        # volts at the centre of the screen
    kind: str = "linear"         # "linear" or "angle" (an analog angle sawtooth)
    volts_per_rev: float = 0.0   # angle: volts per mechanical revolution


@dataclass(frozen=True)
class ScopeChannelMap:
    """The parsed channel map: dialect, ADC bits, screen divisions and the wired channels."""

    dialect: str
    adc_bits: int
    divisions: int
    max_points: int
    channels: tuple[ScopeChannel, ...]
    source: str

    def channel(self, name: str) -> ScopeChannel:
        for channel in self.channels:
            if channel.name == name:
                return channel
        raise InputError(f"scope channel map {self.source}: no channel {name!r} is wired "
                         f"(it has {', '.join(c.name for c in self.channels)})")

    def lsb_si(self, channel: ScopeChannel) -> float:
        """One ADC step of ``channel`` in SI units (rad for an angle channel)."""
        volts = self.divisions * channel.volts_per_div / 2 ** self.adc_bits
        if channel.kind == "angle":
            return volts / channel.volts_per_rev * 2.0 * math.pi
        return volts * channel.si_per_volt

    def screen_v(self, channel: ScopeChannel) -> tuple[float, float]:
        """(bottom, top) of the screen in volts."""
        half = self.divisions * channel.volts_per_div / 2.0
        return channel.offset_v - half, channel.offset_v + half


def load_channel_map(path: str | Path | None = None) -> ScopeChannelMap:
    """Read and check a scope channel map; a bad file raises InputError naming the key."""
    path = Path(path) if path is not None else DEFAULT_CHANNEL_MAP
    try:
        data = tomllib.loads(path.read_text())
    except (OSError, tomllib.TOMLDecodeError) as exc:
        raise InputError(f"scope channel map {str(path)!r} is not readable TOML: {exc}") from None
    try:
        scope = data["scope"]
        channels = tuple(ScopeChannel(c["name"], c["source"], float(c.get("si_per_volt", 1.0)),
                                      float(c["volts_per_div"]), float(c.get("offset_v", 0.0)),
                                      c.get("kind", "linear"), float(c.get("volts_per_rev", 0.0)))
                         for c in data["channels"])
        mapped = ScopeChannelMap(scope["dialect"], int(scope["adc_bits"]),
                                 int(scope.get("divisions", 8)),
                                 int(scope.get("max_points", 1_000_000)), channels, str(path))
    except (KeyError, TypeError, ValueError) as exc:
        raise InputError(f"scope channel map {str(path)!r}: missing or bad key {exc}") from None
    if mapped.dialect not in DIALECTS:
        raise InputError(f"scope channel map {path}: scope.dialect = {mapped.dialect!r}; "
                         f"allowed {', '.join(DIALECTS)}")
    for channel in channels:
        if channel.kind not in ("linear", "angle") or channel.volts_per_div <= 0 or \
                (channel.kind == "angle" and channel.volts_per_rev <= 0):
            raise InputError(f"scope channel map {path}: channel {channel.name}: kind "
                             f"{channel.kind!r}, volts_per_div {channel.volts_per_div} and "
                             "volts_per_rev (angle) must be 'linear'/'angle' and > 0")
    if len({c.source.upper() for c in channels}) != len(channels):
        raise InputError(f"scope channel map {path}: two channels share a source")
    return mapped


@dataclass(frozen=True)
class Preamble:
    """``:WAVeform:PREamble?`` in the order the programmer's guide lists its fields."""

    format: int
    type: int
    points: int
    count: int
    xincrement: float
    xorigin: float
    xreference: int
    yincrement: float
    yorigin: float
    yreference: int

    @classmethod
    def parse(cls, text: str) -> "Preamble":
        parts = text.strip().split(",")
        if len(parts) != len(PREAMBLE_FIELDS):
            raise ValueError(f"a preamble has {len(PREAMBLE_FIELDS)} fields, got {len(parts)}: "
                             f"{text.strip()[:80]!r}")
        values = [float(part) for part in parts]
        ints = {"format", "type", "points", "count", "xreference", "yreference"}
        return cls(**{name: int(value) if name in ints else value
                      for name, value in zip(PREAMBLE_FIELDS, values)})

    def volts(self, codes: np.ndarray) -> np.ndarray:
        return (np.asarray(codes, dtype=float) - self.yreference) * self.yincrement + self.yorigin


class ScopeCaptureError(DeviceFault):
    """A single shot that is not what was asked; ``capture`` holds the data as received."""

    def __init__(self, instrument: str, problems: list[str], capture: Capture) -> None:
        super().__init__(instrument, "check capture integrity", "; ".join(problems))
        self.problems = problems
        self.capture = capture


def _control(get_command: str, set_command: str, cast, doc: str) -> property:
    """A setting as a property: reading asks ``get_command``, writing sends ``set_command``."""

    def getter(self):
        return cast(self.ask(get_command))

    def setter(self, value) -> None:
        self.write(set_command.format(value))

    return property(getter, setter, doc=doc)


class ScpiScope:
    """An oscilloscope on VISA ``resource``; a context manager, or ``connect()``/``close()``."""

    timebase_range_s = _control(":TIMebase:RANGe?", ":TIMebase:RANGe {:.12g}", float,
                                "full-scale horizontal time, s")
    timebase_position_s = _control(":TIMebase:POSition?", ":TIMebase:POSition {:.12g}", float,
                                   "time from the trigger to the reference point, s")
    waveform_points = _control(":WAVeform:POINts?", ":WAVeform:POINts {:d}", int,
                               "points :WAVeform:DATA? returns per channel")
    waveform_source = _control(":WAVeform:SOURce?", ":WAVeform:SOURce {}", str,
                               "the channel :WAVeform queries read")

    def __init__(self, resource: str | None, channel_map=None, timeout_s: float = 10.0,
                 pole_pairs: int | None = None, instrument_name: str = "scope",
                 visa_library: str = "@py") -> None:
        if not resource:
            raise InputError("scope: a VISA resource is needed (e.g. TCPIP::host::5025::SOCKET)")
        self.resource = resource
        self.map = channel_map if isinstance(channel_map, ScopeChannelMap) \
            else load_channel_map(channel_map)
        self.timeout_s = float(timeout_s)
        self.pole_pairs = pole_pairs
        self.name = instrument_name
        self._library = visa_library
        self._manager = None
        self._inst = None
        self._identity: dict | None = None

    # ------------------------------------------------------------------ link
    def connect(self) -> "ScpiScope":
        import pyvisa

        try:
            self._manager = pyvisa.ResourceManager(self._library)
            self._inst = self._manager.open_resource(
                self.resource, read_termination="\n", write_termination="\n",
                timeout=int(self.timeout_s * 1000))
        except (pyvisa.errors.VisaIOError, OSError, ValueError) as exc:
            self._inst = None
            raise TransportLost(self.name, "connect", transport_reason(exc),
                                what=f"cannot open {self.resource}") from exc
        return self

    def close(self) -> None:
        if self._inst is not None:
            try:
                self._inst.close()
            finally:
                self._inst = None

    def __enter__(self) -> "ScpiScope":
        return self.connect()

    def __exit__(self, *exc) -> None:
        self.close()

    def _io(self, action: str, call, *args, **kwargs):
        """One VISA exchange; its failures become the bench's typed errors."""
        import pyvisa

        if self._inst is None:
            raise TransportLost(self.name, action, "not connected")
        try:
            return call(*args, **kwargs)
        except pyvisa.errors.VisaIOError as exc:
            if exc.error_code == pyvisa.constants.StatusCode.error_timeout:
                raise InstrumentTimeout(self.name, action,
                                        f"no answer within {self._inst.timeout / 1000:g} s") \
                    from exc
            raise TransportLost(self.name, action, transport_reason(exc)) from exc
        except OSError as exc:
            raise TransportLost(self.name, action, transport_reason(exc)) from exc
        except ValueError as exc:       # a block or number that does not parse
            raise ProtocolError(self.name, action, str(exc)) from exc

    def write(self, command: str) -> None:
        self._io(f"send {command}", self._inst.write, command)

    def ask(self, query: str) -> str:
        return self._io(f"ask {query}", self._inst.query, query).strip()

    def words(self, query: str) -> np.ndarray:
        """A WORD block (big-endian unsigned 16-bit) answered to ``query``."""
        return self._io(f"read {query}", self._inst.query_binary_values, query, datatype="H",
                        is_big_endian=True, container=np.array, expect_termination=True)

    # ------------------------------------------------------------------ contract
    def identity(self) -> dict:
        """``*IDN?``: manufacturer, model, serial number, firmware."""
        fields = [part.strip() for part in self.ask("*IDN?").split(",")]
        if len(fields) != 4:
            raise ProtocolError(self.name, "ask *IDN?", f"expected 4 fields, got {fields!r}")
        self._identity = dict(zip(("manufacturer", "model", "serial_number", "firmware"),
                                  fields))
        self._identity["dialect"] = self.map.dialect
        return dict(self._identity)

    def status(self) -> dict:
        """The probe: ``*OPC?`` answers 1 on a scope that is there."""
        return {"operation_complete": self.ask("*OPC?") == "1"}

    def disarm(self) -> None:
        """``:STOP``: no acquisition runs."""
        self.write(":STOP")

    def resolution(self) -> dict[str, float]:
        return {channel.name: self.map.lsb_si(channel) for channel in self.map.channels}

    def capture_channels(self, channels=None) -> list[ScopeChannel]:
        """The wired channels a capture of ``channels`` (None: all) reads, in map order."""
        wanted = None if channels is None else set(channels)
        if wanted is not None:
            for name in wanted:
                self.map.channel(name)          # InputError naming the unwired channel
        return [c for c in self.map.channels if wanted is None or c.name in wanted]

    def capture(self, duration_s: float, sample_rate_hz: float, settle_s: float = 0.05,
                timeout_s: float | None = None, channels=None) -> Capture:
        """One ``:DIGitize`` of the wired ``channels`` (None: all), in SI units."""
        if not (math.isfinite(duration_s) and duration_s > 0 and sample_rate_hz > 0):
            raise InputError(f"scope duration_s={duration_s}, sample_rate_hz={sample_rate_hz} "
                             "must be > 0")
        points = int(round(duration_s * sample_rate_hz))
        if not 2 <= points <= self.map.max_points:
            raise InputError(f"scope capture of {points} points; allowed 2.."
                             f"{self.map.max_points} (scope.max_points)")
        chosen = self.capture_channels(channels)
        try:
            self._setup(chosen, points, sample_rate_hz, settle_s)
            self.write(":DIGitize " + ",".join(c.source for c in chosen))
            self._wait_complete(timeout_s if timeout_s is not None
                                else 10.0 + 20.0 * (duration_s + settle_s))
            capture, clipped = self._read(chosen, points, sample_rate_hz, settle_s)
        finally:
            self._stop_quietly()
        if clipped:
            raise ChannelClippedError(self.name, "capture", f"channel(s) {', '.join(clipped)} "
                                      "went off the screen (clipped): widen volts_per_div", clipped)
        return capture

    # ------------------------------------------------------------------ steps
    def _setup(self, chosen, points: int, rate_hz: float, settle_s: float) -> None:
        self.write(":STOP")
        self.write(":ACQuire:TYPE NORMal")
        self.write(":TIMebase:REFerence LEFT")
        self.timebase_range_s = points / rate_hz
        self.timebase_position_s = settle_s
        self.write(":WAVeform:POINts:MODE RAW")
        self.waveform_points = points
        for channel in chosen:
            self.write(f":{channel.source}:SCALe {channel.volts_per_div:.9g}")
            self.write(f":{channel.source}:OFFSet {channel.offset_v:.9g}")
            self.write(f":{channel.source}:DISPlay 1")
        self._check_errors("set up the capture")

    def _wait_complete(self, timeout_s: float) -> None:
        saved = self._inst.timeout
        self._inst.timeout = int(timeout_s * 1000)
        try:
            if self.ask("*OPC?") != "1":
                raise ProtocolError(self.name, "wait for :DIGitize", "*OPC? did not answer 1")
        finally:
            self._inst.timeout = saved

    def _check_errors(self, action: str) -> None:
        """The SCPI error queue (``:SYSTem:ERRor?``) must be empty: an error names the command
        this scope's dialect refused."""
        answer = self.ask(":SYSTem:ERRor?")
        if not answer.lstrip("+").startswith("0"):
            raise DeviceFault(self.name, action, f"the scope reports {answer}")

    def _read(self, chosen, points: int, rate_hz: float, settle_s: float):
        data, lsb, problems, clipped, axis = {}, {}, [], [], None
        for channel in chosen:
            self.waveform_source = channel.source
            self.write(":WAVeform:FORMat WORD")
            self.write(":WAVeform:BYTeorder MSBFirst")
            self.write(":WAVeform:UNSigned 1")
            preamble = Preamble.parse(self.ask(":WAVeform:PREamble?"))
            codes = self.words(":WAVeform:DATA?")
            if preamble.format != WORD_FORMAT or len(codes) != preamble.points:
                raise ProtocolError(self.name, f"read {channel.source}",
                                    f"preamble says format {preamble.format}, "
                                    f"{preamble.points} points; the block held {len(codes)}")
            this_axis = (preamble.points, preamble.xincrement, preamble.xorigin,
                         preamble.xreference)
            if axis is None:
                axis = this_axis
            elif this_axis != axis:
                problems.append(f"{channel.source} has another time axis ({this_axis}) than "
                                f"the first channel ({axis})")
            if np.any(codes == HOLE):
                problems.append(f"{channel.source}: {int(np.sum(codes == HOLE))} holes (points "
                                "not acquired)")
            if np.any((codes == CLIPPED_LOW) | (codes == CLIPPED_HIGH)):
                clipped.append(channel.name)
            volts = preamble.volts(codes)
            if channel.kind == "angle":
                data[channel.name] = np.unwrap(volts / channel.volts_per_rev * 2.0 * math.pi,
                                               period=2.0 * math.pi)
            else:
                data[channel.name] = volts * channel.si_per_volt
            lsb[channel.name] = self.map.lsb_si(channel)
        self._check_errors("read the waveforms")
        n, xincrement, xorigin, xreference = axis
        if n != points:
            problems.insert(0, f"asked for {points} points, the scope returned {n}")
        got_hz = 1.0 / xincrement if xincrement > 0 else float("nan")
        if not abs(got_hz - rate_hz) <= 1e-9 * rate_hz:
            problems.append(f"asked for {rate_hz:g} Hz, the scope sampled at {got_hz:.9g} Hz")
        time_s = (np.arange(n) - xreference) * xincrement
        identity = self._identity or {}
        meta = {"source": "scope", "instrument": self.name, "sample_rate_hz": got_hz,
                "daq_lsb": lsb, "scope_model": identity.get("model"),
                "scope_serial_number": identity.get("serial_number"),
                "scope_dialect": self.map.dialect, "scope_xorigin_s": xorigin,
                "daq_settle_s": settle_s, "daq_clipped": bool(clipped)}
        if self.pole_pairs is not None:
            meta["pole_pairs"] = int(self.pole_pairs)
        capture = Capture(channels={"time_s": time_s, **data}, meta=meta)
        capture.meta["daq_integrity"] = {"checked_time_base": True, "problems": list(problems)}
        if problems:
            raise ScopeCaptureError(self.name, problems, capture)
        return capture, clipped

    def _stop_quietly(self) -> None:
        try:
            self.disarm()
        except InstrumentError:
            pass    # the original error (if any) matters more; the guard stops it again
