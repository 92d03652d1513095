"""The acquisition contract (design §11, §12.2): what the plans need from the instrument that
captures a point, whichever it is.

The plans ask :meth:`Acquisition.capture` for channels by name (``torque_nm``, ``ia_a``,
``ib_a``, ``rotor_angle_mech_rad``, ``vab_v``…), never for a device. Two implementations:
``ripple_hil_drivers.modbus_daq.ModbusDaq`` (the Modbus DAQ, as it is) and
``ripple_hil_drivers.scpi_scope.ScpiScope`` (an oscilloscope over VISA). The bench file's
``[acquisition] kind`` selects one (:data:`KINDS`); the dyno's speed reference is not part of
the contract (it stays on the DAQ's analog output).
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

from hil.capture import Capture

#: ``[acquisition] kind`` -> what it is.
KINDS = {"modbus-daq": "the Modbus DAQ of [daq] (ripple_hil_drivers.modbus_daq)",
         "scpi-scope": "an oscilloscope over VISA (ripple_hil_drivers.scpi_scope)"}


@runtime_checkable
class Acquisition(Protocol):
    """An acquisition instrument: connect, identify, probe, disarm, resolution, capture."""

    name: str

    def connect(self) -> "Acquisition":
        """Open the link; raise the driver's typed error (TransportLost…) if it cannot."""

    def close(self) -> None:
        """Close the link (idempotent)."""

    def identity(self) -> dict:
        """Model, serial number, firmware and the constants the analysis needs."""

    def status(self) -> dict:
        """One cheap question (the probe after an instrument error); raises if it is lost."""

    def disarm(self) -> None:
        """Stop or abort any capture (the safe state)."""

    def resolution(self) -> dict[str, float]:
        """Each channel's LSB in SI units (the uncertainty budget)."""

    def capture(self, duration_s: float, sample_rate_hz: float, settle_s: float = 0.05,
                timeout_s: float | None = None, channels=None) -> Capture:
        """One single-shot capture of ``channels`` (None: all), ``settle_s`` after the call,
        ``duration_s`` long at ``sample_rate_hz``: SI channels with ``time_s`` and the meta
        ``sample_rate_hz``, ``pole_pairs``, ``daq_lsb``. A capture that is not what was asked
        raises an error carrying the data as received (``error.capture``)."""


def make_acquisition(config, daq):
    """The acquisition instrument of bench ``config`` (not connected): the ``[daq]`` driver
    ``daq`` itself, or the oscilloscope of ``[acquisition]``."""
    acquisition = config.acquisition
    if acquisition.kind == "modbus-daq":
        return daq
    from ripple_hil_drivers.scpi_scope import ScpiScope

    return ScpiScope(acquisition.resource, channel_map=acquisition.channel_map,
                     timeout_s=acquisition.timeout_s, pole_pairs=config.motor.pole_pairs,
                     instrument_name="scope")
