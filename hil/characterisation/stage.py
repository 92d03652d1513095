"""The characterisation stage on a bench: captures, identification, record section, and the
bench as measured for the plans (design.md §11, §12.5: set-up before the plans).

Two captures at the bench's operating point, each saved raw in the record before analysis:
the drive disabled with the dyno turning the motor (the back EMF: ψ), then the drive regulating
the operating point's current (R and L at that current, hence at its saturation). The voltage
channel ``vab_v`` is the DAQ's; a DAQ without it identifies nothing and the predictions use the
nameplate, which the record says.
"""

from __future__ import annotations

from hil.characterisation.identify import back_emf, winding
from hil.characterisation.result import Characterisation, ke_from_psi

#: The DAQ's line-to-line terminal voltage channel (drivers/data/daq_registers.toml).
VOLTAGE_CHANNEL = "vab_v"
#: A prime sample rate (as the self-check's): no PWM harmonic aliases onto a steady line and the
#: samples fall at every phase of the PWM period.
SAMPLE_RATE_HZ = 7919.0
#: Electrical revolutions per capture (the type-A scatter needs several).
REVOLUTIONS = 16
#: The simulated DAQ's voltage channel is the mean over the PWM period a sample falls in: its
#: time relative to the current samples is within ± half a PWM period (20 kHz).
VOLTAGE_SKEW_BOUND_S = 0.5 / 20_000.0
SECTION = "characterisation"


def _plan(op, *, enabled: bool):
    from hil.measurement import PointPlan

    return PointPlan(source="characterisation", injection={}, speed_rpm=op.speed_rpm,
                     current_a=op.current_a if enabled else 0.0,
                     current_angle_rad=op.current_angle_rad, kind="self_check", rule=None,
                     drive_enabled=enabled, extra_channels=(VOLTAGE_CHANNEL,),
                     sample_rate_hz=SAMPLE_RATE_HZ, revolutions=REVOLUTIONS)


def has_voltage_channel(bench) -> bool:
    register_map = getattr(bench.daq, "map", None)
    return register_map is None or VOLTAGE_CHANNEL in {ch.name for ch in register_map.channels}


def characterise(bench, record, op=None) -> Characterisation:
    """Identify ψ (as Ke), R and L on ``bench`` at ``op`` (default: the bench file's operating
    point); captures saved in ``record`` as ``characterisation-emf`` / ``-winding``."""
    from hil.measurement import _acquire

    config = bench.config
    op = op or config.operating_point
    if not has_voltage_channel(bench):
        reason = (f"the DAQ's register map has no {VOLTAGE_CHANNEL} channel: no terminal "
                  f"voltage to identify from")
        return Characterisation(not_identified={key: reason for key in (
            "ke_v_s_per_rad", "phase_resistance_ohm", "phase_inductance_h")})
    pole_pairs = config.motor.pole_pairs
    emf_capture = _acquire(bench, record, "characterisation-emf", _plan(op, enabled=False),
                           pole_pairs)
    emf = back_emf(emf_capture, pole_pairs)
    identified = [ke_from_psi(emf.psi, config.motor.ke_definition)]
    not_identified = {}
    if op.current_a > 0:
        winding_capture = _acquire(bench, record, "characterisation-winding",
                                   _plan(op, enabled=True), pole_pairs)
        identified += winding(winding_capture, emf, pole_pairs,
                              skew_bound_s=VOLTAGE_SKEW_BOUND_S)
    else:
        for key in ("phase_resistance_ohm", "phase_inductance_h"):
            not_identified[key] = "the operating point's current is 0 A"
    not_identified.setdefault("current_loop_bandwidth_hz", "no loop test signal in this drive "
                              "profile: the [drive] documentation is used")
    not_identified.setdefault("bandwidth_hz", "the transducer's response is checked by the "
                              "self-check against [torque] bandwidth_hz, not identified")
    return Characterisation(tuple(identified), not_identified)


def run_stage(bench, record) -> Characterisation:
    """Characterise, record the section (stated beside measured, what the predictions use) and
    give the plans the bench as measured (``bench.config``; ``bench.stated_config`` keeps the
    file). On an error the section says so and the error propagates: the plans do not run as
    judged plans (design.md §12.5)."""
    stated = bench.config
    try:
        result = characterise(bench, record)
    except BaseException as exc:
        record.set_section(SECTION, {"failed": f"{type(exc).__name__}: {exc}",
                                     "predictions_use": "none: the plans do not run"})
        raise
    record.set_section(SECTION, result.to_dict(stated))
    bench.stated_config = stated
    bench.characterisation = result
    bench.config = result.measured_config(stated)
    return result
