"""Simulated oscilloscope: a SCPI socket server (port 5025 style: one command per line) speaking
the Keysight InfiniiVision :WAVeform dialect, backed by the same drive twin as the Modbus DAQ.

What each input sees is the channel map the driver uses (``drivers/data/scope_channels.toml``):
a linear channel shows its signal divided by ``si_per_volt``; an angle channel the encoder
interface's analog output, (counts mod counts_per_rev)/counts_per_rev · volts_per_rev. The ADC
quantises the screen (``divisions`` · V/div about ``offset_v``) to ``adc_bits``; WORD codes are
the ADC code left-justified at mid-step (never 0x0000 hole, 0x0001/0xFFFF are clipped low/high).
``:DIGitize`` runs the twin in simulated time: the timebase position (the delay after the
trigger) unrecorded, then to the drive's next PWM valley (the scope is triggered from the drive's
PWM sync output, as the simulated DAQ's sample clock is), then ``:TIMebase:RANGe`` sampled at
``:WAVeform:POINts`` / range. Commands are matched in long or short form, case-insensitive; an
unknown header is SCPI error -113 in the queue ``:SYSTem:ERRor?`` reads. Binds 127.0.0.1.
"""

from __future__ import annotations

import math
import re
import socket
import socketserver
import threading

import numpy as np

from ripple_hil_drivers.scpi_scope import (CLIPPED_HIGH, CLIPPED_LOW, ScopeChannelMap,
                                           load_channel_map)
from ripple_hil_drivers.simulated.modbus_daq_server import _daq_view, _twin_channels, \
    _twin_setting

MNEMONICS = ("WAVeform", "SOURce", "FORMat", "BYTeorder", "UNSigned", "POINts", "MODE",
             "PREamble", "DATA", "TIMebase", "RANGe", "POSition", "REFerence", "ACQuire", "TYPE",
             "DIGitize", "STOP", "RUN", "SINGle", "SYSTem", "ERRor", "CHANnel", "SCALe",
             "OFFSet", "DISPlay")
UNDEFINED_HEADER = '-113,"Undefined header"'
DATA_OUT_OF_RANGE = '-222,"Data out of range"'
SETTINGS_CONFLICT = '-221,"Settings conflict"'


class _Undefined(Exception):
    pass


def canonical(header: str) -> str:
    """A SCPI header in canonical long upper-case form, numeric suffixes kept:
    ``:wav:data?`` -> ``:WAVEFORM:DATA?``, ``:CHAN2:SCAL`` -> ``:CHANNEL2:SCALE``."""
    query = header.endswith("?")
    out = []
    for part in header.rstrip("?").strip(":").split(":"):
        match = re.fullmatch(r"([A-Za-z]+)(\d*)", part)
        if match is None:
            raise _Undefined(header)
        word, digits = match.group(1).upper(), match.group(2)
        for mnemonic in MNEMONICS:
            short = "".join(c for c in mnemonic if c.isupper())
            if word in (short, mnemonic.upper()):
                out.append(mnemonic.upper() + digits)
                break
        else:
            raise _Undefined(header)
    return ":" + ":".join(out) + ("?" if query else "")


class ScopeState:
    """The scope's settings, its acquired record and its error queue (one per server)."""

    def __init__(self, twin, channel_map: ScopeChannelMap, serial_number: str,
                 pwm_synchronous: bool = True) -> None:
        self.twin = twin
        self.map = channel_map
        self.serial_number = serial_number
        self.pwm_synchronous = pwm_synchronous
        self.lock = threading.Lock()
        self.errors: list[str] = []
        self.range_s = 1e-3
        self.position_s = 0.0
        self.points = 1000
        self.vertical = {c.source.upper(): [c.volts_per_div, c.offset_v]
                         for c in channel_map.channels}
        self.source = channel_map.channels[0].source.upper()
        self.format = "WORD"
        self.record: dict[str, np.ndarray] = {}
        self.axis: tuple | None = None

    # ------------------------------------------------------------------ commands
    def handle(self, line: str) -> bytes | None:
        """One program message unit: the answer bytes of a query, None for a command."""
        header, _, argument = line.strip().partition(" ")
        argument = argument.strip()
        if header.upper() == "*IDN?":
            return f"RIPPLE-HIL,SIM-SCOPE-8,{self.serial_number},1.0.0\n".encode()
        if header.upper() == "*OPC?":
            return b"1\n"
        if header.upper() in ("*RST", "*CLS"):
            self.errors.clear()
            return None
        try:
            key = canonical(header)
        except _Undefined:
            self.errors.append(UNDEFINED_HEADER)
            return None
        handler = self._dispatch(key)
        if handler is None:
            self.errors.append(UNDEFINED_HEADER)
            return None
        return handler(key, argument)

    def _dispatch(self, key: str):
        if re.fullmatch(r":CHANNEL\d:(SCALE|OFFSET|DISPLAY)\??", key):
            return self._channel
        return {":SYSTEM:ERROR?": self._error, ":STOP": self._nothing, ":RUN": self._nothing,
                ":ACQUIRE:TYPE": self._nothing, ":TIMEBASE:REFERENCE": self._reference,
                ":TIMEBASE:RANGE": self._number("range_s"), ":TIMEBASE:RANGE?":
                    self._value("range_s"), ":TIMEBASE:POSITION": self._number("position_s"),
                ":TIMEBASE:POSITION?": self._value("position_s"),
                ":WAVEFORM:POINTS:MODE": self._nothing, ":WAVEFORM:POINTS": self._points,
                ":WAVEFORM:POINTS?": self._value("points"), ":WAVEFORM:SOURCE": self._source,
                ":WAVEFORM:SOURCE?": lambda k, a: f"{self.source}\n".encode(),
                ":WAVEFORM:FORMAT": self._format, ":WAVEFORM:BYTEORDER": self._byteorder,
                ":WAVEFORM:UNSIGNED": self._unsigned, ":DIGITIZE": self._digitize,
                ":WAVEFORM:PREAMBLE?": self._preamble, ":WAVEFORM:DATA?": self._data}.get(key)

    def _nothing(self, key, argument):
        return None

    def _error(self, key, argument):
        return ((self.errors.pop(0) if self.errors else '+0,"No error"') + "\n").encode()

    def _value(self, name):
        return lambda key, argument: f"{getattr(self, name):+.9E}\n".encode()

    def _number(self, name):
        def set_number(key, argument):
            try:
                value = float(argument)
            except ValueError:
                self.errors.append(DATA_OUT_OF_RANGE)
                return None
            if not (math.isfinite(value) and (value > 0 or name == "position_s")):
                self.errors.append(DATA_OUT_OF_RANGE)
                return None
            setattr(self, name, value)
            return None
        return set_number

    def _reference(self, key, argument):
        if argument.upper() != "LEFT":       # this simulation keeps the record's start at left
            self.errors.append(SETTINGS_CONFLICT)

    def _points(self, key, argument):
        try:
            points = int(argument)
        except ValueError:
            points = 0
        if not 2 <= points <= self.map.max_points:
            self.errors.append(DATA_OUT_OF_RANGE)
        else:
            self.points = points

    def _channel(self, key, argument):
        source, setting = key.strip(":").split(":")
        if source not in self.vertical:
            self.errors.append(DATA_OUT_OF_RANGE)
            return None
        index = {"SCALE": 0, "OFFSET": 1}.get(setting.rstrip("?"))
        if setting.endswith("?"):
            return f"{self.vertical[source][index or 0]:+.9E}\n".encode()
        if index is not None:
            try:
                self.vertical[source][index] = float(argument)
            except ValueError:
                self.errors.append(DATA_OUT_OF_RANGE)
        return None

    def _source(self, key, argument):
        try:
            self.source = canonical(argument).strip(":")
        except _Undefined:
            self.errors.append(DATA_OUT_OF_RANGE)

    def _format(self, key, argument):
        if argument.upper() not in ("WORD",):     # BYTE and ASCii are not simulated
            self.errors.append(SETTINGS_CONFLICT)

    def _byteorder(self, key, argument):
        if argument.upper() not in ("MSBF", "MSBFIRST"):
            self.errors.append(SETTINGS_CONFLICT)

    def _unsigned(self, key, argument):
        if argument.upper() not in ("1", "ON"):
            self.errors.append(SETTINGS_CONFLICT)

    # ------------------------------------------------------------------ acquisition
    def _digitize(self, key, argument):
        try:
            sources = [canonical(s.strip()).strip(":") for s in argument.split(",")]
        except _Undefined:
            self.errors.append(DATA_OUT_OF_RANGE)
            return None
        wired = {c.source.upper(): c for c in self.map.channels}
        if not sources or any(s not in wired for s in sources):
            self.errors.append(DATA_OUT_OF_RANGE)
            return None
        rate = self.points / self.range_s
        channels = [wired[s] for s in sources]
        asked = _twin_channels(["encoder_counts" if c.kind == "angle" else c.name
                                for c in channels])
        with self.twin.lock:
            if self.position_s > 0:
                self.twin.advance(self.position_s, rate, channels=())
            if self.pwm_synchronous and hasattr(self.twin, "advance_to_carrier_valley"):
                self.twin.advance_to_carrier_valley()
            data = self.twin.advance(self.points / rate, rate, channels=asked)
        view = _daq_view(self.twin, data, asked)
        counts_per_rev = _twin_setting(self.twin, "sensors", "encoder_counts_per_rev") or 7200
        self.record = {}
        for channel in channels:
            if channel.kind == "angle":
                counts = np.mod(np.asarray(view["encoder_counts"], dtype=np.int64),
                                int(counts_per_rev))
                volts = counts / counts_per_rev * channel.volts_per_rev
            else:
                volts = np.asarray(view[channel.name], dtype=float) / channel.si_per_volt
            self.record[channel.source.upper()] = self._adc(channel.source.upper(), volts)
        self.axis = (self.points, 1.0 / rate, self.position_s)
        return None

    def _adc(self, source: str, volts: np.ndarray) -> np.ndarray:
        """WORD codes of ``volts`` on this channel's screen (clipped codes off it)."""
        per_div, offset = self.vertical[source]
        bits = self.map.adc_bits
        full = self.map.divisions * per_div
        steps = np.floor((volts - (offset - full / 2.0)) / full * 2 ** bits)
        words = (np.clip(steps, 0, 2 ** bits - 1).astype(np.int64) << (16 - bits)) \
            + (1 << (15 - bits))
        words[steps < 0] = CLIPPED_LOW
        words[steps >= 2 ** bits] = CLIPPED_HIGH
        return words.astype(np.uint16)

    def _preamble(self, key, argument):
        if self.source not in self.record:
            self.errors.append(SETTINGS_CONFLICT)      # nothing acquired on that source
            return b"\n"
        points, xincrement, xorigin = self.axis
        per_div, offset = self.vertical[self.source]
        yincrement = self.map.divisions * per_div / 65536.0
        fields = (f"{1:+d}", f"{0:+d}", f"{points:+d}", f"{1:+d}", f"{xincrement:+.10E}",
                  f"{xorigin:+.10E}", f"{0:+d}", f"{yincrement:+.10E}", f"{offset:+.10E}",
                  f"{32768:+d}")
        return (",".join(fields) + "\n").encode()

    def _data(self, key, argument):
        if self.source not in self.record:
            self.errors.append(SETTINGS_CONFLICT)
            return b"#10\n"
        payload = self.record[self.source].astype(">u2").tobytes()
        return f"#8{len(payload):08d}".encode() + payload + b"\n"


class _Handler(socketserver.StreamRequestHandler):
    def handle(self) -> None:
        state: ScopeState = self.server.state
        for raw in self.rfile:
            line = raw.decode("ascii", errors="replace").strip()
            if not line:
                continue
            answers = []
            with state.lock:
                for unit in line.split(";"):          # several units on one line
                    answer = state.handle(unit)
                    if answer is not None:
                        answers.append(answer)
            for answer in answers:
                self.wfile.write(answer)
            self.wfile.flush()


class _Server(socketserver.ThreadingTCPServer):
    daemon_threads = True
    allow_reuse_address = True


class SimulatedScope:
    """The simulated scope on 127.0.0.1 (port 0: a free one); ``resource`` is its VISA name."""

    def __init__(self, twin, *, channel_map=None, host: str = "127.0.0.1", port: int = 0,
                 serial_number: str = "SIM-SCOPE-0001", pwm_synchronous: bool = True) -> None:
        mapped = channel_map if isinstance(channel_map, ScopeChannelMap) \
            else load_channel_map(channel_map)
        self.state = ScopeState(twin, mapped, serial_number, pwm_synchronous)
        self._address = (host, port)
        self._server: _Server | None = None
        self._thread: threading.Thread | None = None

    def start(self) -> "SimulatedScope":
        self._server = _Server(self._address, _Handler)
        self._server.state = self.state
        self._thread = threading.Thread(target=self._server.serve_forever, daemon=True,
                                        name="sim-scope")
        self._thread.start()
        return self

    def stop(self) -> None:
        if self._server is not None:
            self._server.shutdown()
            self._server.server_close()
            self._server = None
        if self._thread is not None:
            self._thread.join(5.0)

    def __enter__(self) -> "SimulatedScope":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()

    @property
    def address(self) -> tuple[str, int]:
        if self._server is None:
            raise RuntimeError("simulated scope is not started")
        return self._server.server_address[:2]

    @property
    def resource(self) -> str:
        host, port = self.address
        return f"TCPIP::{host}::{port}::SOCKET"
