"""``[simulation.actual]``: the physics a simulated bench runs when it is not what its file states.

A real bench disagrees with its bench file: the winding is warmer than the nameplate's cold R,
the inductance saturates, the magnets' EMF drifts, the firmware's loop is not exactly its
documented bandwidth, the transducer's not its data sheet's (design.md §11). On a simulated bench
this table is that physics, while the rest of the file stays what the user believes; allowed
only with ``simulated = true``, recorded with the bench file (``bench.loaded.simulation.actual``).

Keys are named as the tables they override (None: as stated there):

| key | overrides | unit |
|---|---|---|
| ``phase_resistance_ohm``, ``phase_inductance_h``, ``ke_v_s_per_rad`` | ``[motor]`` (cold R, unsaturated L, Ke read with ``[motor] ke_definition``) | Ω, H, V·s/rad |
| ``current_loop_bandwidth_hz`` | ``[drive]``: the bandwidth the firmware's PI is designed for, at 20 kHz PWM (its gains set from the ``[motor]`` nameplate, as a drive configured from it) | Hz |
| ``current_loop_delay_s`` | ``[drive]``: (delay periods + 0.5)/20 kHz, so 25, 50, 75 or 100 µs | s |
| ``bandwidth_hz`` | ``[torque]``: the transducer's first-order bandwidth | Hz |
| ``saturation_current_a`` | new: L(|i|) = L/(1 + (|i|/i_sat)²), |i| the current vector's magnitude (peak phase A) | A |
| ``winding_time_constant_s``, ``winding_rise_pu_per_a2`` | new: the winding warms with its copper loss, R = R·(1 + w), τ·dw/dt = k·|i|² − w, w = 0 when the bench starts | s, 1/A² |
| ``daq_voltage_gain`` | new: the Modbus DAQ's line-voltage channel ``vab_v`` reads this × the true voltage: a bench instrument's gain error, which the characterisation's U covers only where the DAQ's ``[[instrument]]`` states an accuracy class that allows it | 1 |

Not a defect: a correct drive on such a bench must pass (the characterisation measures it).
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace

from hil.config import _key, _parse_section

#: the loop delays the simulated firmware runs: (delay periods + 0.5) / 20 kHz, s
SIM_LOOP_DELAYS_S = tuple((periods + 0.5) / 20_000.0 for periods in (0.0, 0.5, 1.0, 1.5))


@dataclass(frozen=True)
class ActualPlant:
    """``[simulation.actual]`` as validated: each field None where the bench file's value holds."""

    phase_resistance_ohm: float | None = _key(None, "float", lo=1e-5, hi=100.0)
    phase_inductance_h: float | None = _key(None, "float", lo=1e-7, hi=1.0)
    ke_v_s_per_rad: float | None = _key(None, "float", lo=1e-4, hi=10.0)
    current_loop_bandwidth_hz: float | None = _key(None, "float", lo=100.0, hi=3000.0)
    current_loop_delay_s: float | None = _key(None, "float", lo=0.0, hi=0.01)
    bandwidth_hz: float | None = _key(None, "float", lo=10.0, hi=1e6)
    saturation_current_a: float | None = _key(None, "float", lo=0.1, hi=1e4)
    winding_time_constant_s: float | None = _key(None, "float", lo=1e-3, hi=1e5)
    winding_rise_pu_per_a2: float | None = _key(None, "float", lo=0.0, hi=1.0)
    daq_voltage_gain: float | None = _key(None, "float", lo=0.9, hi=1.1)

    def _check(self, path: str, ctx) -> None:
        if (self.winding_time_constant_s is None) != (self.winding_rise_pu_per_a2 is None):
            ctx.fail(f"{path}: winding_time_constant_s and winding_rise_pu_per_a2 go together "
                     f"(the warming winding's thermal time constant and its steady rise)")
        if self.current_loop_delay_s is not None and not any(
                abs(self.current_loop_delay_s - d) < 1e-9 for d in SIM_LOOP_DELAYS_S):
            ctx.fail(f"{path}.current_loop_delay_s = {self.current_loop_delay_s:g}: the simulated "
                     f"firmware's delays are " + ", ".join(f"{d:g}" for d in SIM_LOOP_DELAYS_S)
                     + " s ((0, 0.5, 1 or 1.5 periods + 0.5) at 20 kHz)")

    def to_dict(self) -> dict:
        """The keys that were given (None ones left out)."""
        return {f.name: getattr(self, f.name) for f in fields(self)
                if getattr(self, f.name) is not None}

    @classmethod
    def from_dict(cls, d: dict) -> "ActualPlant":
        return cls(**d)

    def motor(self, stated):
        """``stated`` (``hil.motor.MotorParameters``) with the actual R, L and Ke."""
        changes = {name: getattr(self, name) for name in
                   ("phase_resistance_ohm", "phase_inductance_h", "ke_v_s_per_rad")
                   if getattr(self, name) is not None}
        return replace(stated, **changes)


def parse_actual(table, ctx) -> dict:
    """``[simulation.actual]`` validated (``ctx.fail`` naming the key), as the dict of given keys;
    refused on a real bench."""
    if table is None or table == {}:
        return {}
    actual = _parse_section(ActualPlant, table, "simulation.actual", ctx)
    if not ctx.simulated:
        ctx.fail("simulation.actual is the physics of a simulated bench; it is allowed only "
                 "with simulated = true")
    return actual.to_dict()


def actual_twin(config, actual: ActualPlant, stated):
    """``config`` (a ``hil.sim.DriveConfig`` built from the bench file) running ``actual``'s
    physics; the firmware keeps its gains set from the ``stated`` nameplate."""
    from hil.sim import FirmwareModel, TransducerModel

    motor = replace(config.motor, parameters=actual.motor(stated),
                       saturation_current_a=actual.saturation_current_a or 0.0,
                       thermal_time_constant_s=actual.winding_time_constant_s or 0.0,
                       resistance_rise_pu_per_a2=actual.winding_rise_pu_per_a2 or 0.0)
    loop = {"tuning": stated}
    if actual.current_loop_bandwidth_hz is not None:
        loop["bandwidth_per_pwm"] = actual.current_loop_bandwidth_hz / 20_000.0
    if actual.current_loop_delay_s is not None:
        loop["delay_periods"] = round(actual.current_loop_delay_s * 20_000.0 - 0.5, 6)
    firmware: FirmwareModel = replace(config.firmware, **loop)
    transducer = config.transducer
    if actual.bandwidth_hz is not None:
        transducer = TransducerModel(bandwidth_hz=actual.bandwidth_hz,
                                     noise_rms_nm=transducer.noise_rms_nm,
                                     accuracy_class_pct=transducer.accuracy_class_pct)
    return replace(config, motor=motor, firmware=firmware, transducer=transducer)
