"""The characterisation stage on a bench: captures, identification, record section, and the
bench as measured for the plans (design.md §11, §12.5: set-up before the plans).

Two captures at the bench's operating point, each saved raw in the record before analysis:
the drive disabled with the dyno turning the motor (the back EMF: ψ), then the drive regulating
the operating point's current (R and L at that current, hence at its saturation). The voltage
channel ``vab_v`` is the DAQ's; a DAQ without it identifies nothing and the predictions use the
nameplate, which the record says.
"""

from __future__ import annotations

import math
from dataclasses import replace

from hil.characterisation.identify import back_emf, winding
from hil.characterisation.result import Characterisation, ke_from_psi
from hil.characterisation.sampling import sample_rate_hz

#: The DAQ's line-to-line terminal voltage channel (drivers/data/daq_registers.toml).
VOLTAGE_CHANNEL = "vab_v"
#: Electrical revolutions per capture (the type-A scatter needs several).
REVOLUTIONS = 16
#: The simulated DAQ's voltage channel is the mean over the PWM period a sample falls in: its
#: time relative to the current samples is within ± half a PWM period (20 kHz).
VOLTAGE_SKEW_BOUND_S = 0.5 / 20_000.0
SECTION = "characterisation"


def capture_plan(op, pole_pairs: int, *, enabled: bool, revolutions: int = REVOLUTIONS):
    """The point of a voltage capture at ``op``: the drive disabled (the back EMF) or regulating
    ``op``'s current (the winding), at ``sampling.sample_rate_hz`` for those revolutions."""
    from hil.measurement import PointPlan

    return PointPlan(source="characterisation", injection={}, speed_rpm=op.speed_rpm,
                     current_a=op.current_a if enabled else 0.0,
                     current_angle_rad=op.current_angle_rad, kind="self_check", rule=None,
                     drive_enabled=enabled, extra_channels=(VOLTAGE_CHANNEL,),
                     sample_rate_hz=sample_rate_hz(op.speed_rpm, pole_pairs, revolutions),
                     revolutions=revolutions)


def has_voltage_channel(bench) -> bool:
    register_map = getattr(bench.daq, "map", None)
    return register_map is None or VOLTAGE_CHANNEL in {ch.name for ch in register_map.channels}


def characterise(bench, record, op=None) -> Characterisation:
    """Identify ψ (as Ke), R and L on ``bench`` at ``op`` (default: the bench file's operating
    point); captures saved in ``record`` as ``characterisation-emf`` / ``-winding``."""

    config = bench.config
    op = op or config.operating_point
    if not has_voltage_channel(bench):
        reason = (f"the DAQ's register map has no {VOLTAGE_CHANNEL} channel: no terminal "
                  f"voltage to identify from")
        return Characterisation(not_identified={key: reason for key in (
            "ke_v_s_per_rad", "phase_resistance_ohm", "phase_inductance_h")})
    pole_pairs = config.motor.pole_pairs
    note = ""
    for attempt in range(len(SLOWER_SPEED_FACTORS) + 1):
        emf_capture = voltage_capture(bench, record, "characterisation-emf",
                                      capture_plan(op, pole_pairs, enabled=False), pole_pairs)
        if not isinstance(emf_capture, str) or attempt == len(SLOWER_SPEED_FACTORS):
            break
        slower = replace(op, speed_rpm=op.speed_rpm * SLOWER_SPEED_FACTORS[attempt])
        note = (f"characterised at {slower.speed_rpm:.0f} rpm, not the operating point's "
                f"{op.speed_rpm:g} rpm: {emf_capture}")
        op = slower
    if isinstance(emf_capture, str):
        return Characterisation(not_identified={key: emf_capture for key in (
            "ke_v_s_per_rad", "phase_resistance_ohm", "phase_inductance_h",
            "current_loop_bandwidth_hz", "bandwidth_hz")})
    gain_u_rel = config.daq_gain_u_rel()
    emf = back_emf(emf_capture, pole_pairs, gain_u_rel=gain_u_rel)
    identified = [ke_from_psi(emf.psi, config.motor.ke_definition)]
    not_identified = {}
    winding_capture = (voltage_capture(bench, record, "characterisation-winding",
                                       capture_plan(op, pole_pairs, enabled=True), pole_pairs)
                       if op.current_a > 0 else "the operating point's current is 0 A")
    if not isinstance(winding_capture, str):
        identified += winding(winding_capture, emf, pole_pairs,
                              skew_bound_s=VOLTAGE_SKEW_BOUND_S, gain_u_rel=gain_u_rel)
    else:
        for key in ("phase_resistance_ohm", "phase_inductance_h"):
            not_identified[key] = winding_capture
    if len(identified) == 3:
        loop, transducer = _loop(bench, record, op, identified, config, emf.psi.value)
        for key, found in (("current_loop_bandwidth_hz", loop), ("bandwidth_hz", transducer)):
            if isinstance(found, str):
                not_identified[key] = found
            else:
                identified += found
    if not any(item.name == "bandwidth_hz" for item in identified):
        not_identified.setdefault("bandwidth_hz", "no loop test-signal captures to measure the "
                                  "transducer's response from (the motor was not identified)")
    return Characterisation(tuple(identified), not_identified, note, emf=emf, point=op)


#: Where the terminal voltage at the operating point is beyond the DAQ's voltage channel, the
#: stage retries at these fractions of its speed (Ke, R and the saturated L at the operating
#: current do not depend on the speed; the loop fit models the electrical frequency).
SLOWER_SPEED_FACTORS = (0.6, 0.35)


def voltage_capture(bench, record, name, plan, pole_pairs):
    """A capture with the terminal voltage, or the reason there is none: a ``vab_v`` beyond the
    DAQ's range (e.g. a 48 V bus at speed on a ±32.8 V channel) identifies nothing, and the
    plans run on the nameplate; any other clipped channel is the bench's failure."""
    from ripple_hil_drivers.errors import ChannelClippedError

    from hil.measurement import _acquire

    try:
        return _acquire(bench, record, name, plan, pole_pairs)
    except ChannelClippedError as exc:
        if set(exc.channels) != {VOLTAGE_CHANNEL}:
            raise
        return (f"the terminal voltage is beyond the DAQ's {VOLTAGE_CHANNEL} range at "
                f"{plan.speed_rpm:g} rpm ({exc.detail})")


#: The loop test signal: amplitude as a share of the operating current (clear of the ADC's LSB
#: and of the current limit), at rotor-frame frequencies this share of the documented bandwidth.
LOOP_TEST_SHARE = 0.1
LOOP_TEST_FREQUENCIES_PU = (0.25, 0.5, 1.0)
#: The loop captures' DAQ rate: the PWM ripple's first harmonics (20…200 kHz) fold to ≥ 1.95 kHz
#: and not synchronously with the carrier; at 7919 Hz the 40 kHz ripple folded onto 405 Hz
#: (order 24 at 500 rpm) and moved that point by 7 %.
LOOP_SAMPLE_RATE_HZ = 47_317.0
LOOP_REVOLUTIONS = 8
#: A loop gain measured with U (k = 2) at or above this confirms nothing: the documented loop may
#: be ±30 % off (testplans/test_characterisation.py), so such a fit is "not identified". The
#: coverage study's U/g has median 2.5 % (studies/results/characterisation_coverage.md); a review
#: found 2152 ± 14302 Hz "confirmed" on a drive whose delay was 100 µs against 75 µs documented.
#: Relative to g as well: a fit of the wrong design read g = 0.05 ± 0.073 on a 2-DOF loop stated
#: as a PI (the h-2dof review), a U of 146 % of what it states.
LOOP_GAIN_RESOLVABLE_U_PU = 0.3
#: The drive's PWM frequency while characterised (the EDS default; nothing injected), Hz.
PWM_HZ = 20_000.0


def _loop(bench, record, op, identified, config, psi_v_s_per_rad):
    """From the loop test signal's captures: the loop's gain relative to its documentation
    (``loop.fit_loop``) and the transducer's bandwidth (``transducer.fit_bandwidth``), each a
    list of Identified or the reason it was not identified; ``psi_v_s_per_rad``: the measured
    peak phase EMF per mechanical rad/s."""
    reason = _loop_refusal(bench, config)
    if reason is not None:
        return reason, f"no loop test-signal captures ({reason})"
    return _loop_captures(bench, record, op, identified, config, psi_v_s_per_rad)


def _loop_refusal(bench, config) -> str | None:
    """Why the loop test signal cannot be used on this bench (None: it can)."""
    drive = config.drive
    if drive.current_loop_design != "continuous":
        return (f"the fit knows the documented 'continuous' PI design only, the bench file "
                f"states {drive.current_loop_design!r}")
    if drive.current_loop_bandwidth_hz is None or drive.current_loop_delay_s is None:
        return "the bench file states no [drive] current_loop_bandwidth_hz/delay to compare with"
    if "loop_test_amplitude_a" not in bench.drive.injection_limits():
        return "the drive has no loop test-signal objects (0x200C/0x200D)"
    return None


def _loop_captures(bench, record, op, identified, config, psi_v_s_per_rad):
    """The loop test signal's captures and both fits (``_loop``)."""
    from hil.characterisation.loop import angle_count_elec_rad, fit_loop, response
    from hil.characterisation.transducer import fit_bandwidth, response_magnitude
    from hil.measurement import _acquire
    from hil.sim.injection import Injection

    drive = config.drive
    pole_pairs = config.motor.pole_pairs
    f_e = abs(op.speed_rpm) / 60.0 * pole_pairs
    amplitude = round(min(10.0, max(0.5, LOOP_TEST_SHARE * op.current_a)), 3)
    high = int(Injection.ranges()["loop_test_order"].max)
    orders = sorted({min(high, max(2, round(share * drive.current_loop_bandwidth_hz / f_e)))
                     for share in LOOP_TEST_FREQUENCIES_PU})
    by_name = {item.name: item for item in identified}
    plant = (by_name["phase_resistance_ohm"].value, by_name["phase_inductance_h"].value)
    beyond = {order: needed for order in orders
              if (needed := loop_test_voltage_v(op, pole_pairs, order, amplitude, plant,
                                                psi_v_s_per_rad)) > _loop_voltage_limit_v(config)}
    orders = [order for order in orders if order not in beyond]
    if len(orders) < 2:
        reason = (f"the loop test signal ({amplitude:g} A at orders "
                  + ", ".join(f"{k} (needs {v:.3g} V)" for k, v in beyond.items())
                  + f") would take the drive beyond its linear voltage "
                  f"{_loop_voltage_limit_v(config):.3g} V (peak phase) at this point: a "
                  f"saturated loop reads slow; fewer than two orders remain")
        return reason, f"no loop test-signal captures ({reason})"
    points, transducer_points, count_elec_rad = [], [], 0.0
    for order in orders:
        plan = replace(capture_plan(op, pole_pairs, enabled=True),
                       injection={"loop_test_amplitude_a": amplitude, "loop_test_order": order},
                       extra_channels=(), sample_rate_hz=LOOP_SAMPLE_RATE_HZ,
                       revolutions=LOOP_REVOLUTIONS)
        capture = _acquire(bench, record, f"characterisation-loop-k{order}", plan, pole_pairs)
        points.append((order, *response(capture, pole_pairs, order, amplitude,
                                         op.current_angle_rad)))
        transducer_points.append(response_magnitude(capture, pole_pairs, order))
        count_elec_rad = angle_count_elec_rad(capture, pole_pairs)
    transducer = (fit_bandwidth(transducer_points, config.torque.bandwidth_hz)
                  if config.torque.bandwidth_hz is not None
                  else "the bench file states no [torque] bandwidth_hz (no first-order model)")
    transducer = transducer if isinstance(transducer, str) else [transducer]
    setup = _loop_setup(op, config, plant, psi_v_s_per_rad, count_elec_rad)
    gain = fit_loop(points, setup, plant, by_name["phase_inductance_h"].u)
    if gain.expanded >= LOOP_GAIN_RESOLVABLE_U_PU * min(1.0, gain.value):   # absolute or of g
        return (f"the measured response does not pin the loop down against its documented "
                f"design and delay: g = {gain.value:.3g} ± {gain.expanded:.3g} (k = 2), a U of "
                f"{LOOP_GAIN_RESOLVABLE_U_PU:.0%} or more (of 1 or of g) cannot confirm nor "
                f"refute the documentation (e.g. a loop delay or a design other than the "
                f"documented one)"), transducer
    return [gain], transducer


def loop_test_voltage_v(op, pole_pairs, order, amplitude_a, plant, psi_v_s_per_rad) -> float:
    """Peak phase voltage (V) the loop test signal needs at ``op``, bounded above: the operating
    point's steady voltage on the measured motor (``plant`` = (R Ω, L H), E = ψ·ω_m) plus the test
    current's (``amplitude_a`` peak at rotor-frame order ``order``, which the stator sees at
    (order ± 1)·ωe) through |R + j·(order + 1)·ωe·L|."""
    from hil.characterisation.loop import phase_voltage_peak_v

    omega_m = op.speed_rpm * 2 * math.pi / 60.0
    omega_e = pole_pairs * omega_m
    steady = phase_voltage_peak_v(op.current_a, op.current_angle_rad, omega_e,
                                  psi_v_s_per_rad * omega_m, plant)
    resistance, inductance = plant
    return steady + amplitude_a * abs(complex(resistance, (order + 1) * abs(omega_e) * inductance))


def _loop_voltage_limit_v(config) -> float:
    """The linear SVPWM limit (peak phase V) of the drive as characterised (EDS defaults: no
    injected dead time, ``PWM_HZ``)."""
    from hil.model.voltage import linear_limit_v

    return linear_limit_v(config.motor.dc_bus_v, pwm_frequency_hz=PWM_HZ)


def _loop_setup(op, config, plant, psi_v_s_per_rad, count_elec_rad):
    """``loop.LoopSetup`` at ``op``: the documented loop, the PWM, and the legs' duties from the
    operating point's voltage on the measured motor (E = ψ·ω_m)."""
    from hil.characterisation.loop import LoopSetup, phase_voltage_peak_v, svpwm_duties

    omega_m = op.speed_rpm * 2 * math.pi / 60.0
    omega_e = config.motor.pole_pairs * omega_m
    voltage = phase_voltage_peak_v(op.current_a, op.current_angle_rad, omega_e,
                                   psi_v_s_per_rad * omega_m, plant)
    drive = config.drive
    return LoopSetup(omega_e_rad_s=omega_e, bandwidth_hz=drive.current_loop_bandwidth_hz,
                     delay_s=drive.current_loop_delay_s,
                     tuned=(config.motor.phase_resistance_ohm, config.motor.phase_inductance_h),
                     pwm_hz=PWM_HZ, count_elec_rad=count_elec_rad,
                     duties=svpwm_duties(voltage, config.motor.dc_bus_v))


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


def motor_bounds_of(bench) -> dict:
    """Where the characterised motor's R, L and Ke may lie (``Characterisation.motor_bounds``,
    each ± U, k = 2) on ``bench``; empty where the stage did not run. The validity regions'
    guard band decides at them (``hil.validity.guarded_voltage_problems``)."""
    result = getattr(bench, "characterisation", None)
    if result is None:
        return {}
    return result.motor_bounds(getattr(bench, "stated_config", None) or bench.config)
