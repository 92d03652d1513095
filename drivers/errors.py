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


class InjectionRangeError(LimitError, InputError):
    """A fault-injection or command value outside the range the drive's EDS (or the drive) allows.

    Both a ``LimitError`` (for the safety guard) and an ``InputError`` (the CLI prints it on one
    line and exits 2): the message names the knob, the value and the allowed range.
    """
