"""The oscilloscope as the acquisition instrument (issue 31 item 3): the Keysight InfiniiVision
:WAVeform dialect byte-exact as its programmer's guide spells it, over pyvisa-py's raw socket; a
single shot of the simulated scope agrees with the Modbus DAQ's capture of an identical twin to
within the two instruments' LSBs; clipping, dialect errors and a wrong rate are refused."""

from __future__ import annotations

import math
import socket
import threading

import numpy as np
import pytest

from hil.acquisition import Acquisition
from hil.sim import DriveTwin
from ripple_hil_drivers.errors import DeviceFault, LimitError
from ripple_hil_drivers.modbus_daq import ModbusDaq, ModbusTcpSettings
from ripple_hil_drivers.scpi_scope import (Preamble, ScopeCaptureError, ScpiScope,
                                           load_channel_map)
from ripple_hil_drivers.simulated.modbus_daq_server import SimulatedDaq
from ripple_hil_drivers.simulated.scpi_scope_server import SimulatedScope, canonical

#: The programmer's guide's example block header: "#8" then 8 digits, 00001000 bytes follow.
MANUAL_HEADER = b"#800001000"


@pytest.fixture(scope="module", autouse=True)
def compiled_twin_engine():
    """Compile (or load) the twin's engine once, before any capture waits on it."""
    from hil.sim.warmup import prepare_twin_engine

    prepare_twin_engine()


def twin(seed=0):
    drive = DriveTwin(seed=seed)
    with drive.lock:
        drive.speed_rpm = 1000.0
        drive.current_command_a = 10.0
        drive.enable()
    return drive


class ScriptedPeer:
    """A raw SCPI socket peer: records every line the driver sends, answers queries from a
    dict (bytes, sent as they are)."""

    def __init__(self, answers: dict[str, bytes]) -> None:
        self.answers = answers
        self.lines: list[str] = []
        self.listener = socket.create_server(("127.0.0.1", 0))
        self.thread = threading.Thread(target=self._serve, daemon=True)
        self.thread.start()

    @property
    def resource(self) -> str:
        return "TCPIP::127.0.0.1::%d::SOCKET" % self.listener.getsockname()[1]

    def _serve(self) -> None:
        connection, _ = self.listener.accept()
        with connection, connection.makefile("rb") as reader:
            for raw in reader:
                line = raw.decode().rstrip("\n")
                self.lines.append(line)
                if line in self.answers:
                    connection.sendall(self.answers[line])
        self.listener.close()


def test_the_manuals_frames_byte_exact():
    """Commands as the guide spells them; its example block header #800001000 (1000 bytes =
    500 WORD points, MSB first) and a preamble in its field order parse to the volts of its
    formula (code - yreference) * yincrement + yorigin."""
    codes = (np.arange(500) * 131 + 7).astype(">u2")
    block = MANUAL_HEADER + codes.tobytes() + b"\n"
    preamble = b"+1,+0,+500,+1,+1.0000000000E-05,+0.0000000000E+00,+0,+1.5258789062E-04," \
               b"+2.0000000000E+00,+32768\n"
    peer = ScriptedPeer({":WAVeform:PREamble?": preamble, ":WAVeform:DATA?": block})
    with ScpiScope(peer.resource, pole_pairs=2) as scope:
        scope.waveform_source = "CHANnel1"
        scope.write(":WAVeform:FORMat WORD")
        parsed = Preamble.parse(scope.ask(":WAVeform:PREamble?"))
        words = scope.words(":WAVeform:DATA?")
    assert peer.lines == [":WAVeform:SOURce CHANnel1", ":WAVeform:FORMat WORD",
                          ":WAVeform:PREamble?", ":WAVeform:DATA?"]
    assert words.tolist() == codes.tolist()
    assert (parsed.format, parsed.points, parsed.xincrement, parsed.yreference) == \
        (1, 500, 1e-5, 32768)
    np.testing.assert_allclose(parsed.volts(words[:2]),
                               (np.array([7, 138]) - 32768) * 1.5258789062e-4 + 2.0)


def test_simulated_scope_answers_in_the_manuals_block_format():
    with SimulatedScope(twin()) as sim, socket.create_connection(sim.address, timeout=60) as s:
        s.sendall(b":TIMebase:RANGe 0.005\n:WAVeform:POINts 500\n:DIGitize CHANnel1\n"
                  b":WAVeform:SOURce CHANnel1\n:WAVeform:FORMat WORD\n:WAV:DATA?\n")
        answer = b""
        while len(answer) < len(MANUAL_HEADER) + 1000 + 1:
            answer += s.recv(4096)
    assert answer.startswith(MANUAL_HEADER) and answer.endswith(b"\n")
    assert len(answer) == len(MANUAL_HEADER) + 1000 + 1


def test_short_and_long_forms_are_one_command():
    assert canonical(":wav:data?") == canonical(":WAVeform:DATA?") == ":WAVEFORM:DATA?"
    assert canonical(":CHAN2:SCAL") == ":CHANNEL2:SCALE"


def test_scope_and_daq_capture_the_same_drive_within_their_lsbs():
    """Two identical twins, one behind the Modbus DAQ, one behind the scope: each channel agrees
    to within half an LSB of each instrument (the angle modulo whole revolutions)."""
    with SimulatedDaq(twin(seed=5)) as server, \
            ModbusDaq(ModbusTcpSettings(*server.address)) as daq:
        by_daq = daq.capture(0.02, 20_000.0, settle_s=0.01)
    with SimulatedScope(twin(seed=5)) as sim, ScpiScope(sim.resource, pole_pairs=2) as scope:
        scope.identity()
        by_scope = scope.capture(0.02, 20_000.0, settle_s=0.01)
    assert by_scope.meta["source"] == "scope" and by_scope.meta["sample_rate_hz"] == 20_000.0
    np.testing.assert_allclose(by_scope["time_s"], by_daq["time_s"], rtol=1e-12, atol=1e-15)
    for name in ("torque_nm", "ia_a", "ib_a", "vab_v", "rotor_angle_mech_rad"):
        bound = 0.5 * (by_scope.meta["daq_lsb"][name] + by_daq.meta["daq_lsb"][name]) + 1e-12
        difference = by_scope[name] - by_daq[name]
        if name == "rotor_angle_mech_rad":
            difference -= 2 * math.pi * np.round(difference[0] / (2 * math.pi))
        assert np.max(np.abs(difference)) <= bound, name
        assert np.ptp(by_daq[name]) > 5 * bound, name           # a signal, not a constant


def test_both_instruments_satisfy_the_acquisition_contract():
    scope = ScpiScope("TCPIP::127.0.0.1::1::SOCKET")
    daq = ModbusDaq(ModbusTcpSettings("127.0.0.1", 1))
    assert isinstance(scope, Acquisition) and isinstance(daq, Acquisition)
    daq.close()


def test_a_clipped_channel_is_refused(tmp_path):
    """A torque channel set too sensitive (the simulated wiring as shipped): LimitError."""
    text = load_channel_map().source
    tight = tmp_path / "tight.toml"
    tight.write_text(open(text).read().replace("volts_per_div = 0.5\noffset_v = 1.5",
                                               "volts_per_div = 0.01\noffset_v = 0.0"))
    with SimulatedScope(twin(), channel_map=tight) as sim, \
            ScpiScope(sim.resource, channel_map=tight) as scope:
        with pytest.raises(LimitError, match="torque_nm"):
            scope.capture(0.005, 20_000.0, settle_s=0.0, channels=["torque_nm"])


def test_a_command_the_scope_does_not_know_is_named(tmp_path):
    """A dialect mismatch shows in the SCPI error queue: DeviceFault with the scope's words."""
    with SimulatedScope(twin()) as sim, ScpiScope(sim.resource) as scope:
        scope.write(":WAVeform:STReaming ON")          # Infiniium, not InfiniiVision
        with pytest.raises(DeviceFault, match="-113"):
            scope._check_errors("probe the dialect")


def test_a_scope_that_samples_at_another_rate_is_refused():
    """The scope decides its rate from range and points; a scope that rounds its timebase
    (here: the range 10 % long) gives another rate, and the capture is refused with the data."""
    class RoundingScope(ScpiScope):
        def _setup(self, chosen, points, rate_hz, settle_s):
            super()._setup(chosen, points, rate_hz, settle_s)
            self.timebase_range_s = 1.1 * points / rate_hz

    with SimulatedScope(twin()) as sim, RoundingScope(sim.resource) as scope:
        with pytest.raises(ScopeCaptureError, match="sampled at") as error:
            scope.capture(0.005, 20_000.0, settle_s=0.0, channels=["ia_a"])
    assert len(error.value.capture["ia_a"]) == 100
