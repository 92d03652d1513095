"""Typed instrument errors: each says which instrument failed and what it was doing.

Drivers raise these (never bare library exceptions) so the safety guard and the record can tell a
timeout from a protocol fault from a device-reported fault.
"""

from __future__ import annotations

from hil.errors import HilError, InputError


class InstrumentError(HilError):
    """An instrument failed while doing something.

    ``instrument`` names it as the bench file does (e.g. "drive", "daq", "torque"), ``action`` says
    what the driver was doing ("SDO write 0x2001:00 ia_offset_a", "read capture buffer page 3").
    """

    def __init__(self, instrument: str, action: str, detail: str) -> None:
        self.instrument = instrument
        self.action = action
        self.detail = detail
        super().__init__(f"{instrument}: {action}: {detail}")


class InstrumentTimeout(InstrumentError):
    """No (complete) answer in time: SDO timeout, Modbus timeout, serial silence."""


class ProtocolError(InstrumentError):
    """A malformed, unexpected or corrupted answer: bad frame, checksum, garbage, SDO abort."""


class DeviceFault(InstrumentError):
    """The instrument itself reports a fault: CANopen EMCY, CiA 402 fault state, Modbus exception."""


class HeartbeatLost(InstrumentError):
    """A CANopen heartbeat consumer saw the producer go silent."""


class LimitError(InstrumentError):
    """A command or a measured value is outside the bench's configured limits."""


class ChannelClippedError(LimitError):
    """A capture channel sat at the end of its range: the capture would understate what it
    measured. ``channels`` names the clipped channels (empty when the instrument did not say)."""

    def __init__(self, instrument: str, action: str, detail: str, channels=()) -> None:
        self.channels = tuple(channels)
        super().__init__(instrument, action, detail)


class InjectionRangeError(LimitError, InputError):
    """A fault-injection or command value outside the range the drive's EDS (or the drive) allows.

    Both a ``LimitError`` (for the safety guard) and an ``InputError`` (the CLI prints it on one
    line and exits 2): the message names the knob, the value and the allowed range.
    """


class TransportLost(InstrumentError):
    """No working link to the instrument: it could not be reached (connection refused, no such
    port) or the link broke (connection reset or closed, broken pipe, serial port gone, CAN bus or
    its remote bridge gone).

    ``reason`` is what the operating system (or the protocol library) said, e.g. "[Errno 111]
    Connection refused"; the message carries it after ``what`` ("connection lost", "cannot
    connect to 127.0.0.1:502"). Drivers raise it ``from`` the original exception.
    """

    def __init__(self, instrument: str, action: str, reason: str,
                 what: str = "connection lost") -> None:
        self.reason = reason
        super().__init__(instrument, action, f"{what}: {reason}")


def transport_reason(error: BaseException) -> str:
    """The operating system's reason behind ``error``: the innermost OS-level error in its chain
    of causes and contexts (``[Errno 104] Connection reset by peer``; ``termios.error(5, ...)``
    reads ``[Errno 5] Input/output error``), else the innermost OSError, else the innermost error,
    with its type (``WebsocketClosed: Status: 1006, reason: Socket closed unexpectedly``)."""
    chain, seen = [], set()
    while error is not None and id(error) not in seen:
        seen.add(id(error))
        chain.append(error)
        error = error.__cause__ or error.__context__
    with_errno = [e for e in chain if _errno_text(e)]
    if with_errno:
        return _errno_text(with_errno[-1])
    os_errors = [e for e in chain if isinstance(e, OSError) and str(e)]
    chosen = os_errors[-1] if os_errors else chain[-1]
    text = " ".join(str(chosen).split())
    return f"{type(chosen).__name__}: {text}" if text else type(chosen).__name__


def _errno_text(error: BaseException) -> str:
    """"[Errno N] reason" of an OS-level error (an OSError, or termios.error's (N, reason)
    arguments), "" for anything else."""
    if isinstance(error, OSError) and error.errno is not None:
        return " ".join(str(error).split())
    args = error.args
    if len(args) == 2 and isinstance(args[0], int) and isinstance(args[1], str) \
            and type(error).__module__ in ("termios", "select", "socket"):
        return f"[Errno {args[0]}] {args[1]}"
    return ""
