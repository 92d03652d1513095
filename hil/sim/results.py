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

def transducer_gain_error(config: DriveConfig, rng: np.random.Generator) -> float:
    """The unit's fixed gain error (per unit of reading), uniform within its accuracy class."""
    return float(rng.uniform(-1.0, 1.0)) * config.transducer.accuracy_class_pct / 100.0


def name_channels(out: np.ndarray, config: DriveConfig, gain_error_pu: float,
                  rng: np.random.Generator) -> dict[str, np.ndarray]:
    """Engine output rows -> standard channels; adds the transducer reading ``torque_nm``.

    The engine's channels are rows of ``out`` (views, not copies: ``out`` belongs to the result).
    """
    channels = {name: out[row] for row, (name, _) in ENGINE_CHANNELS.items()}
    channels["encoder_counts"] = out[L.C_COUNTS].astype(np.int64)
    torque = (1.0 + gain_error_pu) * out[L.C_TORQUE_SHAFT_FILTERED]
    if config.transducer.noise_rms_nm > 0:
        torque += rng.normal(0.0, config.transducer.noise_rms_nm, out.shape[1])
    channels["torque_nm"] = torque
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
        return len(self.channels["time_s"])

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
    }
