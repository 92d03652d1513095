"""The plant contract: what the simulated instruments use of the drive + dyno behind them.

Written from ``drivers/simulated/`` as they are (drive_node, modbus_daq_server, transducer_pty):
nothing here is new behaviour. ``hil.sim.DriveTwin`` satisfies it unchanged; an independent
simulator is a second implementation (``hil.plants.motulator_plant``).

Time is simulated: ``advance`` runs the plant forward and never sleeps; consecutive calls join
up. Commands and injections changed between calls take effect from the next call. Every member
may be called from any thread; ``lock`` (re-entrant) makes a sequence of calls atomic — the DAQ
holds it for a whole capture, the drive reads ``status()`` only when it is free.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any, Protocol, runtime_checkable

import numpy as np

#: ``status()`` keys every plant reports (SI units; counts of the encoder's own resolution)
STATUS_KEYS = ("torque_nm", "torque_em_nm", "speed_rpm", "position_counts", "ia_a", "ib_a",
               "dc_bus_v", "time_s")

#: ``advance`` channels the DAQ's register map asks for (``drivers/data/daq_registers.toml``;
#: ``vab_v`` is made of ``va_v`` and ``vb_v``, the phase-to-negative-rail voltages)
DAQ_CHANNELS = ("ia_a", "ib_a", "encoder_counts", "torque_nm", "dc_bus_v", "va_v", "vb_v")


@runtime_checkable
class Plant(Protocol):
    """The drive under test on a speed-holding dyno, as the simulated instruments see it.

    - ``lock``: a re-entrant lock (``acquire(blocking=, timeout=)``, ``release``, ``with``).
    - ``injection``: the injection knobs as commanded (``hil.sim.Injection``: one attribute per
      knob, SI units); the drive's read-back of every knob object.
    - ``set_injection(**knobs)``: ValueError (knob and allowed range) leaves them unchanged;
      a plant that cannot realise a knob's value refuses it the same way.
    - ``restore_defaults()``: every knob back to its default.
    - ``enable()`` / ``disable()``: power stage on (current regulated to the command) / off
      (no current; the controller's integrators reset).
    - ``current_command_a`` (A, amplitude of the phase current; the angle φ is a knob) and
      ``speed_rpm`` (the dyno's setpoint, signed): readable and settable; ValueError refuses.
    - ``advance(duration_s, sample_rate_hz, *, settle_s=0.0, channels=None)``: run ``settle_s``
      unrecorded, then ``duration_s`` sampled at ``sample_rate_hz``; the named channels as
      arrays (``time_s`` in simulated seconds; ``encoder_counts`` integers; ``torque_nm`` the
      transducer's reading, ``torque_em_nm`` the air-gap torque). An unknown name is a
      ValueError.
    - ``status()``: the latest scalars, :data:`STATUS_KEYS`.

    Optional members the instruments look for with ``getattr``: ``advance_to_carrier_valley()``
    (a PWM-synchronous DAQ starts on a counter valley), ``config.sensors.encoder_counts_per_rev``
    and ``config.motor.parameters.pole_pairs`` (the DAQ's identity registers), ``defects``
    (``hil.sim.defects.DriveDefects``, test-only), ``identity`` (which plant: a string).
    """

    lock: Any

    @property
    def injection(self) -> Any: ...

    def set_injection(self, **values: float) -> None: ...

    def restore_defaults(self) -> None: ...

    def enable(self) -> None: ...

    def disable(self) -> None: ...

    current_command_a: float
    speed_rpm: float

    def advance(self, duration_s: float, sample_rate_hz: float, *, settle_s: float = 0.0,
                channels: Iterable[str] | None = None) -> Mapping[str, np.ndarray]: ...

    def status(self) -> dict: ...


def plant_identity(plant) -> str:
    """Which plant computes the samples: its ``identity``, else the ripple-hil twin's."""
    identity = getattr(plant, "identity", None)
    if identity:
        return str(identity)
    from hil import __version__

    return f"ripple-hil twin (hil.sim) {__version__}"
