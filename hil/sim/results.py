"""Named, unit-carrying outputs of the engine and the transducer's measurement errors."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from hil.capture import Capture
from hil.sim import layout as L
from hil.sim.config import DriveConfig

#: engine output row -> (standard channel name, unit)
ENGINE_CHANNELS: dict[int, tuple[str, str]] = {
    L.C_TIME: ("time_s", "s"),
    L.C_THETA_M: ("rotor_angle_mech_rad", "rad"),
    L.C_COUNTS: ("encoder_counts", "counts"),
    L.C_IA: ("ia_a", "A"),
    L.C_IB: ("ib_a", "A"),
    L.C_IC: ("ic_a", "A"),
    L.C_TORQUE_EM: ("torque_em_nm", "N*m"),
    L.C_TORQUE_SHAFT: ("torque_shaft_nm", "N*m"),
    L.C_SPEED_RPM: ("speed_rpm", "rpm"),
    L.C_ID: ("id_a", "A"),
    L.C_IQ: ("iq_a", "A"),
    L.C_VA: ("va_v", "V"),
    L.C_VB: ("vb_v", "V"),
    L.C_VC: ("vc_v", "V"),
    L.C_IA_SENSED: ("ia_sensed_a", "A"),
    L.C_IB_SENSED: ("ib_sensed_a", "A"),
}

#: every standard channel a run can return, in the order results list them
STANDARD_CHANNELS: tuple[str, ...] = tuple(name for name, _ in ENGINE_CHANNELS.values()) \
    + ("torque_nm", "dc_bus_v")


def select_channels(channels) -> tuple[tuple[str, ...], np.ndarray]:
    """(names in standard order, engine row map) for a selection of standard channel names.

    ``channels``: None (all) or an iterable of names; an unknown name is a ValueError naming it
    and the valid ones. The row map (``layout.N_CHANNELS`` int64) gives each engine channel's
    row in the output array the engine fills, −1 where no asked channel needs it (``torque_nm``
    needs the transducer front end ``C_TORQUE_SHAFT_FILTERED``; ``dc_bus_v`` none).
    """
    if channels is None:
        names = STANDARD_CHANNELS
    else:
        if isinstance(channels, str):
            raise ValueError(f"channels must be an iterable of channel names, not the string "
                             f"{channels!r}")
        try:
            asked = set(channels)
        except TypeError:
            raise ValueError(f"channels must be None or an iterable of channel names, not "
                             f"{channels!r}") from None
        unknown = sorted(asked.difference(STANDARD_CHANNELS), key=str)
        if unknown:
            raise ValueError(f"unknown channel {unknown[0]!r}; valid channels: "
                             f"{', '.join(STANDARD_CHANNELS)}")
        names = tuple(name for name in STANDARD_CHANNELS if name in asked)
    engine_row = {name: row for row, (name, _) in ENGINE_CHANNELS.items()}
    engine_row["torque_nm"] = L.C_TORQUE_SHAFT_FILTERED
    rows = np.full(L.N_CHANNELS, -1, dtype=np.int64)
    for row in sorted(engine_row[name] for name in names if name in engine_row):
        rows[row] = int((rows >= 0).sum())
    return names, rows


#: arguments of an engine run that records nothing (settling): no rows, nothing at the end
NO_SAMPLES = np.zeros((0, 0))
NO_ROWS = np.full(L.N_CHANNELS, -1, dtype=np.int64)
NO_LATEST = np.zeros(L.N_CHANNELS)


def transducer_gain_error(config: DriveConfig, rng: np.random.Generator) -> float:
    """The unit's fixed gain error (per unit of reading), uniform within its accuracy class."""
    return float(rng.uniform(-1.0, 1.0)) * config.transducer.accuracy_class_pct / 100.0


#: samples of transducer noise drawn at a time (added in place, chunk by chunk)
_NOISE_CHUNK = 1 << 16


def name_channels(out: np.ndarray, rows: np.ndarray, names: tuple[str, ...],
                  config: DriveConfig, gain_error_pu: float,
                  rng: np.random.Generator) -> dict[str, np.ndarray]:
    """The engine's output rows as the standard channels ``names`` (see ``select_channels``).

    No copies: engine channels are rows of ``out`` (``encoder_counts`` an int64 view of its
    row, which the engine wrote as integers); ``torque_nm``, the transducer's reading, is its
    front-end row scaled by the gain error and given its noise in place (drawn only when asked,
    so a run without ``torque_nm`` leaves ``rng`` where it was). ``out`` belongs to the result.
    """
    channels = {}
    for row, (name, _) in ENGINE_CHANNELS.items():
        if name in names:
            channels[name] = out[rows[row]]
    if "encoder_counts" in names:
        channels["encoder_counts"] = out[rows[L.C_COUNTS]].view(np.int64)
    if "torque_nm" in names:
        torque = out[rows[L.C_TORQUE_SHAFT_FILTERED]]
        torque *= 1.0 + gain_error_pu
        sigma = config.transducer.noise_rms_nm
        if sigma > 0:                         # the same draws as rng.normal(0, sigma, n)
            noise = np.empty(min(len(torque), _NOISE_CHUNK))
            for start in range(0, len(torque), _NOISE_CHUNK):
                chunk = noise[:min(_NOISE_CHUNK, len(torque) - start)]
                rng.standard_normal(out=chunk)
                chunk *= sigma
                torque[start:start + len(chunk)] += chunk
        channels["torque_nm"] = torque
    if "dc_bus_v" in names:
        channels["dc_bus_v"] = np.full(out.shape[1], config.motor.parameters.dc_bus_v)
    return channels


def channel_units() -> dict[str, str]:
    units = {name: unit for name, unit in ENGINE_CHANNELS.values()}
    units.update(torque_nm="N*m", dc_bus_v="V")
    return units


@dataclass
class SimResult:
    """Simulated channels (dict-like, SI units in the names), their units and metadata.

    Besides the standard channels: ``ia_a``/``ib_a``/``ic_a`` are the actual phase currents and
    ``ia_sensed_a``/``ib_sensed_a`` what the firmware read (ADC value held over the PWM period);
    ``torque_em_nm`` = Σ e_x·i_x/ω_m, ``torque_shaft_nm`` adds cogging, ``torque_nm`` is the
    transducer's reading of the shaft torque (bandwidth, gain error, noise); ``id_a``/``iq_a``
    use the true rotor angle; ``va_v``/``vb_v``/``vc_v`` are line-to-neutral voltages averaged
    over the PWM period containing the sample.
    """

    channels: dict[str, np.ndarray]
    units: dict[str, str] = field(default_factory=channel_units)
    meta: dict = field(default_factory=dict)

    def __getitem__(self, name: str) -> np.ndarray:
        return self.channels[name]

    def __contains__(self, name: str) -> bool:
        return name in self.channels

    def __iter__(self):
        return iter(self.channels)

    def keys(self):
        return self.channels.keys()

    def items(self):
        return self.channels.items()

    def __len__(self) -> int:
        """Samples per channel (0 for a run that asked for no channel)."""
        return len(next(iter(self.channels.values()))) if self.channels else 0

    def to_capture(self) -> Capture:
        """A ``hil.capture.Capture`` with the standard channel names and meta."""
        return Capture(channels=dict(self.channels), units=dict(self.units), meta=dict(self.meta))


def result_meta(config: DriveConfig, sample_rate_hz: float, seed: int,
                gain_error_pu: float) -> dict:
    return {
        "source": "simulation",
        "pole_pairs": config.motor.parameters.pole_pairs,
        "sample_rate_hz": float(sample_rate_hz),
        "encoder_counts_per_rev": config.sensors.encoder_counts_per_rev,
        "seed": int(seed),
        "current_command_a": config.current_command_a,
        "speed_rpm_command": config.speed_rpm,
        "injection": config.injection.as_dict(),
        "transducer_gain_error_pu": gain_error_pu,
        # the angle channel is the twin's rotor angle, whose θe = 0 is phase a's back-EMF rising
        # zero crossing by construction (hil/diagnosis/README.md)
        "emf_a_rising_zero_elec_deg": 0.0,
        "emf_a_rising_zero_u_elec_deg": 0.0,
        "emf_a_rising_zero_source": "simulation: the angle channel is the twin's rotor angle",
    }
