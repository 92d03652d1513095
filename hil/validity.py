"""Where each plan's verdict may be given: one declared validity region per source (design.md §9).

A point outside its plan's region is *not determinable here*: the pre-flight skips it with
``pytest.skip(not_determinable(reason))`` before any bench command (``hil.preflight``,
``fixtures/preflight.py``); it is neither a pass nor a fail. The bench's hard safety limits
(``[limits]``) stay hard errors, checked apart (``hil.preflight.hard_problems``).

What a region checks, in the order a refusal names it:

1. **Direction.** Reverse rotation under the positive torque the plans command is *braking*
   (``hil.model.voltage``). A model that takes the drive as mirrored motoring is refused there.
2. **Speed** |n| within the range the model assumes (the encoder plan runs at its own 12 rpm).
3. **Voltage headroom.** The peak phase voltage the inverter must give — the steady phasor with
   the signed speed (braking in reverse) plus the dead time's (4/π)·T_d·f_pwm·V_dc along the
   current — within the SVPWM limit less the dead times every edge must keep inside the period,
   (V_dc/√3)·(1 − 4·T_d·f_pwm) (``hil.model.voltage.linear_limit_v``, the one limit, its reason
   there); beyond it the current is not regulated or the highest leg clips and its dead-time
   error vanishes, and no model of the paper applies. An injected sensor offset or gain error
   makes the loop drive a current of its own on top (its voltage is added,
   ``hil.model.voltage``), and on the bench as characterised the headroom must hold at every
   corner of the measured R, L and Ke ± U (k = 2) (:func:`guarded_voltage_problems`).
4. **Capture.** The DAQ's rate and buffer, the Nyquist order of the analysed band
   (rate / (2·f_e) ≥ max_order). The PWM-switching plan adapts its capture instead: its DAQ rate
   and revolutions are derived from the speed and PWM frequency
   (``hil.analysis.switching.capture_settings``), which refuses with the reason what the DAQ
   cannot capture.
5. **Resolvable ripple.** The bench's resolvable pk-pk floor must take at most ``floor_fraction``
   of the rule's acceptance half-width at the point (rel_tol·predicted + abs_tol, or the distance
   from the prediction to the top of a derived model's range + abs_tol; per unit of the nameplate
   mean torque K_t·I·cos φ). The floor is two counts of the torque reading's stated resolution
   (``[[instrument]] resolution`` of the DAQ or transducer, in N·m: a pk-pk cannot be read finer
   than ±1 count), or, with no resolution stated, the transducer's accuracy class × full scale.
   With 0.5 the floor's bias can take at most half of the band, the rest is left to the model's
   and the measurement's own error. This refuses what the bench cannot resolve: an encoder 2.5°
   point at 10 A (0.0042 N·m predicted against a 0.001 N·m floor) or word length 12 bit at
   250 rpm / 10 A, which failed a correct drive when judged at the bench's own floor (issue 21).
6. **Whole orders.** The order a rule judges must be a whole order over the analysed period
   (:func:`period_problems`, issue 30): an encoder count order that is not a whole number per
   electrical revolution is analysed over the staircase's common period, or refused.
7. **Loop design and delay** a point's model can represent: the stated
   ``current_loop_design`` among the model's ``REPRESENTED_LOOP_DESIGNS`` (a PI-only model
   cannot judge a point on a "2dof" loop, whose integral action α_c²·L it would take for
   R·ω_c: :func:`loop_design_problems`), the sampled-loop delay (PWM resolution:
   :func:`loop_delay_problems`); and **the simulated plant**: an injection the bench's
   ``[simulation] plant`` cannot realise (``hil.plants.capabilities``; issue 30).
8. **Plant corner within the calibrated band** (dead time; issue 30): the electrical order at
   the plant's pole, k_c = R/(L·|ω_e|), at most the largest the plan's bands were calibrated at
   (``Region.max_plant_corner_order``: Table I at 125 rpm, 54.6; :func:`corner_problems`). The
   PI's zero cancels the plant pole, so a voltage disturbance reaches the current through
   s/((R + L·s)(s + ω_c)): ∝ k up to order k_c. Beyond the analysed band's orders the dead-time torque ripple is spread evenly over
   every analysed order (a pulse at each current zero crossing) and its pk-pk is small against
   the drive's own ripple: the 2-pole 24 V study motor at ±250 rpm (k_c = 153, L/R 0.25 ms) read
   1.2-1.66× the model's pk-pk at every capture rate (2-20 kHz), the drive's own pk-pk with no
   dead time 0.11-0.17 % against 0.10-0.47 % predicted, and order 6 at 0.88-1.12×.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from hil.config import BenchConfig
from hil.errors import InputError

#: The bench floor may take at most this fraction of a rule's acceptance half-width (docstring 5).
FLOOR_FRACTION = 0.5
#: Counts of the torque reading's resolution that make the resolvable pk-pk floor (±1 count).
FLOOR_COUNTS = 2.0


@dataclass(frozen=True)
class Region:
    """Where one plan's model and band hold (module docstring).

    ``braking``: the model is right in reverse rotation under positive torque (braking);
    ``speed_rpm``: the |speed| range of the plan's point, rpm (every plan needs a regulated
    current, so the voltage headroom is checked for all); ``floor_fraction``: the bench floor
    may take at most this share of the rule's acceptance half-width (None: the plan judges no
    ripple prediction against the floor); ``max_plant_corner_order``: the largest
    R/(L·|ω_e|) the plan's bands were calibrated at (None: no limit; docstring 8); ``why``:
    the region's reason, in words.
    """

    braking: bool
    why: str
    speed_rpm: tuple[float, float] = (0.0, math.inf)
    floor_fraction: float | None = FLOOR_FRACTION
    max_plant_corner_order: float | None = None

    def to_dict(self) -> dict:
        """JSON-safe (an open upper speed bound is None), for the record's agreed rules."""
        low, high = self.speed_rpm
        return {"braking": self.braking, "speed_rpm": [low, None if math.isinf(high) else high],
                "floor_fraction": self.floor_fraction,
                "max_plant_corner_order": self.max_plant_corner_order,
                "why": self.why}


#: The dead-time plan's largest plant corner order R/(L·|ω_e|) (docstring 8): the calibration
#: set's largest judged (studies/dead_time_calibration.py: Table I, L/R 0.70 ms, at 125 rpm on 2
#: pole pairs, k_c = 54.6; every judged point within the plan's bands), rounded up to 55.
#: Checked on the holdout set (motors B and C, Table I: every judged point inside it passes as
#: before). Not raised from the study motors: the validity study judges there
#: (hil/model/README.md, "Low L/R at low speed").
DEAD_TIME_MAX_PLANT_CORNER_ORDER = 55.0


def plant_corner_order(config: BenchConfig, speed_rpm: float) -> float:
    """k_c = R/(L·|ω_e|): the electrical order at the plant's pole R/L (inf at standstill)."""
    motor = config.motor
    elec_rad_s = abs(speed_rpm) / 60.0 * 2.0 * math.pi * motor.pole_pairs
    if elec_rad_s == 0.0:
        return math.inf
    return motor.phase_resistance_ohm / (motor.phase_inductance_h * elec_rad_s)


def corner_problems(plan, config: BenchConfig, region: Region) -> list[str]:
    """The plant corner order beyond the region's calibrated one (docstring 8)."""
    limit = region.max_plant_corner_order
    if limit is None:
        return []
    corner = plant_corner_order(config, plan.speed_rpm)
    if corner <= limit:
        return []
    motor = config.motor
    tau_ms = 1e3 * motor.phase_inductance_h / motor.phase_resistance_ohm
    return [f"plant corner beyond the {plan.source} calibration: R/(L·ω_e) = order {corner:.3g} "
            f"at {plan.speed_rpm:g} rpm (L/R {tau_ms:.2g} ms) vs <= {limit:g} (the loop rejects "
            "the disturbance up to that order, so the ripple spreads over every analysed order "
            "and is not resolved from the drive's own ripple; hil/model/README.md)"]


REGIONS: dict[str, Region] = {
    "encoder": Region(
        braking=True, speed_rpm=(0.0, 60.0),
        why="eqs 7-9 are quasi-static (rotor stepped slowly, the loop settles within each encoder "
            "step): the plan runs at +12 rpm whatever the bench's point and judges the count "
            "order's pk-pk 2·A_N (at standstill the current ADC's quantisation pattern, fixed in "
            "θ, lifts the staircase's pk-pk but not A_N); per unit it is independent of the "
            "current, so low current is limited by the floor"),
    "word_length": Region(
        braking=True,
        why="the truncation bias acts like a dc offset on both sensors (order 1), independent of "
            "the EMF's sign; the computed-I_q errors reach the reading through the stated loop "
            "and transducer (hil.model.word_length); 12-bit ripple is near the floor at low "
            "current; a motor below the validated L/R is refused by the plan"),
    "dc_offset": Region(
        braking=True,
        why="eqs 15-20: the order-1 ripple depends on |I| and the offsets only, not on the EMF's "
            "sign"),
    "gain_mismatch": Region(
        braking=True,
        why="eqs 21-26: the order-2 ripple depends on |I| and the gains only, not on the EMF's "
            "sign"),
    "pwm_resolution": Region(
        braking=True,
        why="derived duty-quantisation model; reverse rotation is taken as braking "
            "(hil.model.pwm_resolution.forward_phasor_peak_v); the noise check's range spans the "
            "quantised loop's trials (where the references sit within a count is unknown) and "
            "a counter whose U covers half its range is not determinable"),
    "pwm_switching": Region(
        braking=True, floor_fraction=None,
        why="switched-circuit torque under SVPWM; reverse rotation is braking (the forward-"
            "equivalent phasor of hil.model.pwm_resolution); the plan derives its DAQ rate from "
            "the speed and PWM frequency (hil.analysis.switching.capture_settings, judged on "
            "every window the capture holds) and refuses "
            "itself, with the reason, a point the DAQ cannot capture or whose U covers its "
            "acceptance zone"),
    "dead_time": Region(
        braking=True, max_plant_corner_order=DEAD_TIME_MAX_PLANT_CORNER_ORDER,
        why="current-clamping model (average leg error from the current at each leg's edges: "
            "PWM ripple and zero-current clamping at the crossings, the stated loop and "
            "transducer, signed speed: braking in reverse); needs every edge's dead time inside "
            "the period (the voltage limit with 1 - 4*T_d*f_pwm); the order-6 ripple is small "
            "(0.1-1 %) and, on a motor whose loop rejects order 6 at low electrical frequency "
            "(2 poles, low speed), below what the bench resolves; validated up to the plant "
            "corner order R/(L*w_e) of its calibration"),
    "baseline": Region(
        braking=True,
        why="nothing injected, judged against the 1 % ceiling; needs a regulated current"),
    "self_check": Region(
        braking=True, floor_fraction=None,
        why="torque scale, current channels and speed against the command: needs a regulated "
            "current (voltage headroom) and a capture the DAQ can hold"),
    "ripple_map": Region(
        braking=True, floor_fraction=None,
        why="the drive as it is, no model verdict: a cell is measured only where the current is "
            "regulated"),
    "characterisation": Region(
        braking=True, floor_fraction=None,
        why="the loop's gain measured by the characterisation stage against its documented "
            "design; the stage itself says what it could not identify (hil.characterisation), "
            "and the plan is not determinable then"),
    "diagnosis": Region(
        braking=True, floor_fraction=None,
        why="designed points, no model verdict; fitted with the forward models, which need a "
            "regulated current"),
}


def region_of(source: str) -> Region | None:
    """The declared region of a source's plan (None: a user's source without one)."""
    return REGIONS.get(source)


def refusal(plan, config: BenchConfig) -> str | None:
    """Why ``plan`` (a :class:`hil.measurement.PointPlan`) cannot be judged on this bench: the
    first limit it breaks, "<which limit>, <value> vs <limit>" (None: inside its region)."""
    reasons = problems(plan, config)
    return reasons[0] if reasons else None


def problems(plan, config: BenchConfig) -> list[str]:
    """Every region limit ``plan`` breaks (module docstring, in that order; empty: fine)."""
    region = region_of(plan.source) or Region(braking=True, why="no declared region")
    found = []
    if plan.speed_rpm < 0 and not region.braking:
        found.append(f"reverse rotation is braking, outside the {plan.source} model: speed "
                     f"{plan.speed_rpm:g} rpm vs >= 0 rpm")
    low, high = region.speed_rpm
    if not low <= abs(plan.speed_rpm) <= high:
        found.append(f"speed outside the {plan.source} model's range: |{plan.speed_rpm:g}| rpm "
                     f"vs {low:g}..{high:g} rpm")
    found += voltage_problems(plan, config)
    found += corner_problems(plan, config, region)
    found += capture_problems(plan, config)
    found += period_problems(plan, config)
    if region.floor_fraction is not None and plan.rule is not None:
        found += floor_problems(plan, config, region.floor_fraction)
    found += loop_design_problems(plan, config)
    found += loop_delay_problems(plan)
    from hil.plants.capabilities import plant_problems   # what the simulated plant cannot do

    found += plant_problems(plan, config)
    return found


def loop_design_problems(plan, config: BenchConfig) -> list[str]:
    """The stated loop design outside the design(s) the point's model represents (its module's
    ``REPRESENTED_LOOP_DESIGNS``; docstring 7): checked where the plan predicts with the stated
    loop (its prediction takes ``current_loop_bandwidth_hz``)."""
    if "current_loop_bandwidth_hz" not in plan.prediction_params:
        return []
    import importlib

    from hil.model import SOURCES

    function = SOURCES.get(plan.source)
    represented = None if function is None else getattr(
        importlib.import_module(function.__module__), "REPRESENTED_LOOP_DESIGNS", None)
    design = config.drive.current_loop_design
    if represented is None or design in represented:
        return []
    return [f"current loop design outside the {plan.source} model: the bench file states "
            f"current_loop_design = {design!r}, the model represents {', '.join(represented)} "
            "only (hil.current_loop)"]


def loop_delay_problems(plan) -> list[str]:
    """A loop delay the point's sampled-loop model cannot represent (the PWM-resolution noise
    model: computation delays of 0, ½, 1 or 1½ PWM periods; a drive updating twice per carrier
    period has 0.75 in all). Until issue 30 this refused the whole run at pre-flight."""
    delay_s = plan.prediction_params.get("current_loop_delay_s")
    if plan.source != "pwm_resolution" or delay_s is None:
        return []
    from hil.model.pwm_noise import computation_delay_periods

    try:
        computation_delay_periods(delay_s, plan.injection.get("pwm_frequency_hz", 20_000.0))
    except InputError as exc:
        return [f"loop delay outside the pwm_resolution noise model: {exc}"]
    return []


def injected_or_default(plan, config: BenchConfig, knob: str) -> float:
    """The point's value of a drive knob: its injection, else the value the drive runs at (SI;
    its profile's restore value, ``ripple_hil_drivers.drive_profile.DriveProfile.value_si``)."""
    if knob in plan.injection:
        return float(plan.injection[knob])
    from ripple_hil_drivers.drive_profile import profile_for

    return float(profile_for(config.drive).value_si(knob))


#: Injections whose current the loop drives on top of the commanded one (``hil.model.voltage``).
SENSOR_ERROR_KNOBS = ("ia_offset_a", "ib_offset_a", "ia_gain_error_pu", "ib_gain_error_pu")


def voltage_problems(plan, config: BenchConfig) -> list[str]:
    """The inverter's peak phase voltage against V_dc/√3 (``hil.model.voltage``), the current
    the point's injected sensor errors make the loop drive included."""
    needed, available = _voltage_needed_and_available(plan, config)
    return [] if needed <= available else [_voltage_reason(plan, config, needed, available)]


def guarded_voltage_problems(plan, config: BenchConfig, bounds: dict) -> list[str]:
    """The voltage headroom (:func:`voltage_problems`) at the corners of the characterisation's
    bounds (``Characterisation.motor_bounds``: R, L, Ke each low or high within its U, k = 2,
    taken together: conservative where their errors are independent): a point that keeps its
    headroom with the values the predictions use but not at some corner may be beyond the limit
    on this motor, and is refused with the figures of the corner that needs most (a guard band
    of the measured parameters' U; docstring 3). Empty where every corner keeps it, or where
    the point is refused without the guard (:func:`voltage_problems` names that)."""
    from dataclasses import replace
    from itertools import product

    names = [name for name in ("phase_resistance_ohm", "phase_inductance_h", "ke_v_s_per_rad")
             if name in bounds]
    if not names or voltage_problems(plan, config):
        return []
    corners = []
    for corner in product(*(bounds[name] for name in names)):
        motor = replace(config.motor, **dict(zip(names, corner)))
        needed, available = _voltage_needed_and_available(plan, replace(config, motor=motor))
        corners.append((needed, available, corner))
    needed, available, corner = max(corners, key=lambda c: c[0] - c[1])
    if needed <= available:
        return []
    where = ", ".join(f"{name} = {value:.4g}" for name, value in zip(names, corner))
    return [f"voltage headroom within the characterisation's uncertainty: at {where} (the "
            f"measured values ± U, k = 2) it "
            + _voltage_reason(plan, config, needed, available).split(": ", 1)[1]]


def _voltage_needed_and_available(plan, config: BenchConfig) -> tuple[float, float]:
    from hil.model.voltage import inverter_voltage_needed_v, linear_limit_v

    dead_time_s = injected_or_default(plan, config, "dead_time_s")
    pwm_hz = injected_or_default(plan, config, "pwm_frequency_hz")
    needed = inverter_voltage_needed_v(
        config.motor, plan.speed_rpm, plan.current_a, plan.current_angle_rad,
        dead_time_s=dead_time_s, pwm_frequency_hz=pwm_hz, sensor_errors=_sensor_errors(plan))
    return needed, linear_limit_v(config.motor.dc_bus_v, dead_time_s, pwm_hz)


def _sensor_errors(plan) -> dict:
    return {knob: float(plan.injection[knob]) for knob in SENSOR_ERROR_KNOBS
            if knob in plan.injection}


def _voltage_reason(plan, config: BenchConfig, needed: float, available: float) -> str:
    dead_time_s = injected_or_default(plan, config, "dead_time_s")
    limit = ("V_dc/√3, SVPWM" if dead_time_s == 0 else
             f"V_dc/√3·(1 − 4·T_d·f_pwm), SVPWM whose every edge keeps its "
             f"{dead_time_s * 1e6:g} us dead time within the period")
    with_errors = " and the injected sensor errors' current" if _sensor_errors(plan) else ""
    return (f"voltage headroom: needs {needed:.2f} V peak phase voltage at {plan.speed_rpm:g} "
            f"rpm, {plan.current_a:g} A (dead time {dead_time_s * 1e6:g} us{with_errors} "
            f"included) vs {available:.2f} V ({limit})")


def capture_problems(plan, config: BenchConfig) -> list[str]:
    """The DAQ's rate and buffer and the analysed band's Nyquist order. (The switching analysis'
    equivalent-time sampling is the PWM-switching plan's own choice and refusal:
    ``hil.analysis.switching.capture_settings``.)"""
    from ripple_hil_drivers.daq_register_map import load_register_map

    device = load_register_map(config.daq.register_map).device
    pole_pairs = config.motor.pole_pairs
    rate = plan.capture_rate_hz(pole_pairs)
    samples = int(round(plan.capture_duration_s(pole_pairs) * rate))
    found = []
    if rate > float(device["max_sample_rate_hz"]):
        found.append(f"capture rate {rate:g} Hz exceeds the DAQ's max_sample_rate_hz = "
                     f"{device['max_sample_rate_hz']}")
    if samples > int(device["buffer_capacity_samples"]):
        found.append(f"capture of {samples} samples exceeds the DAQ's "
                     f"buffer_capacity_samples = {device['buffer_capacity_samples']}")
    # orders are numbered over the analysed period (PointPlan.period_revolutions)
    nyquist_orders = rate / 2.0 / plan.period_frequency_hz(pole_pairs)
    if plan.analysis == "torque" and plan.max_order > nyquist_orders:
        found.append(f"max_order {plan.max_order} is above what {rate:g} Hz can resolve at "
                     f"{plan.speed_rpm:g} rpm (order {nyquist_orders:.0f})")
    return found


def period_problems(plan, config: BenchConfig) -> list[str]:
    """The predicted order must be a whole order over the analysed period (docstring 6): a
    count order of 57.6 per electrical revolution (7200 counts, 10 poles, decimation 25) judged
    over one revolution is a smeared line; the plan analyses over the common period
    (``PointPlan.period_revolutions``, ``hil.model.encoder.count_period``) or, where that
    period's order lies beyond its analysed band, the point is not determinable here."""
    if plan.rule is None or plan.source == "baseline":
        return []
    from hil.measurement import analysed_order
    from hil.measurement import _predict as predict_plan

    try:
        op = config.model_point(plan.speed_rpm, plan.current_a, plan.current_angle_rad,
                                allow_beyond_voltage_limit=True)
        prediction = predict_plan(plan, op)
        analysed_order(prediction.order, plan)
    except InputError as exc:
        if "not a whole order" not in str(exc):
            return []               # another limit's reason (the floor check names it)
        period = (prediction.extras or {}).get("count_period")
        beyond = ("" if not period else
                  f"; its common period of {period[0]} electrical revolutions puts it at order "
                  f"{period[1]}, beyond the analysed band (max_order {plan.max_order})")
        return [f"order not whole over the analysed period: {prediction.order:.6g} per "
                f"electrical revolution over {plan.period_revolutions}{beyond}"]
    return []


def bench_floor_nm(config: BenchConfig) -> float:
    """The bench's resolvable torque pk-pk, N·m (module docstring 5): two counts of the stated
    torque resolution, else the transducer's accuracy class × full scale."""
    inputs = config.uncertainty_inputs()
    if inputs["daq_lsb_nm"]:
        return FLOOR_COUNTS * float(inputs["daq_lsb_nm"])
    return inputs["transducer_accuracy_class_pct"] / 100.0 * inputs["transducer_full_scale_nm"]


#: Fourier terms of the dithered quantiser's residual error summed (the series converges fast).
DITHER_TERMS = 8


def dithered_quantiser_error_nm(lsb_nm: float, noise_rms_nm: float) -> float:
    """Largest error of the *mean* of many readings of a quantiser of step q with Gaussian
    noise σ ahead of it: (q/π)·Σ_k exp(−2π²k²σ²/q²)/k (the sawtooth's Fourier series, each term
    damped by the noise's characteristic function), at most q/2 (no noise: the reading's own
    ±½ count, a pattern fixed in θ that no averaging removes)."""
    if noise_rms_nm <= 0:
        return lsb_nm / 2.0
    ratio = (noise_rms_nm / lsb_nm) ** 2
    series = sum(math.exp(-2.0 * math.pi ** 2 * k * k * ratio) / k
                 for k in range(1, DITHER_TERMS + 1))
    return min(lsb_nm / 2.0, lsb_nm / math.pi * series)


def resolvable_floor_nm(plan, config: BenchConfig) -> float:
    """The pk-pk (or named order's 2·A) the bench's reading lends a ripple-free point, N·m
    (docstring 5), from the stated resolution q and noise σ (``[torque] noise_rms_nm``) and the
    point's own capture: 2 × the dithered quantiser's residual error
    (:func:`dithered_quantiser_error_nm`) + the noise left in the figure — for a pk-pk the
    extremes of B independent points of the synchronous average (B = 2·max_order + 1 Fourier
    terms, ×8 bins for the ``bins`` method), each with σ_b = √(σ² + q²/12)/√(M/B) over the M
    samples captured, lifting it by 2·√(2·ln B)·σ_b; for a named order's 2·A the Fourier sum's
    2·2·√(σ² + q²/12)·√(2/M) (k = 2). Without a stated noise the fixed two counts stay."""
    inputs = config.uncertainty_inputs()
    lsb = inputs["daq_lsb_nm"]
    noise = getattr(config.torque, "noise_rms_nm", None)
    if not lsb or noise is None or plan.analysis != "torque":
        return bench_floor_nm(config)
    pole_pairs = config.motor.pole_pairs
    samples = plan.capture_rate_hz(pole_pairs) * plan.revolutions / plan.period_frequency_hz(
        pole_pairs)
    spread = math.sqrt(noise ** 2 + lsb ** 2 / 12.0)
    quantiser = 2.0 * dithered_quantiser_error_nm(lsb, noise)
    if plan.rule is not None and plan.rule.quantity == "named_order_pk_pk":
        return quantiser + 2.0 * 2.0 * spread * math.sqrt(2.0 / samples)
    points = (2 * plan.max_order + 1) * (8 if plan.pk_pk_method == "bins" else 1)
    per_point = spread / math.sqrt(max(1.0, samples / points))
    return quantiser + 2.0 * math.sqrt(2.0 * math.log(points)) * per_point


def acceptance_half_width_pu(rule, predicted_pu: float,
                             expected_range_pu: tuple[float, float] | None) -> float:
    """How far above the prediction a measured pk-pk may read and still be accepted, per unit of
    the nameplate mean torque: the rule's band on the side the floor pushes (upward)."""
    if rule.expected_range and expected_range_pu is not None:
        return max(0.0, expected_range_pu[1] * (1.0 + rule.rel_tol) - predicted_pu) \
            + rule.abs_tol_pu
    if rule.upper_bound:
        return max(0.0, predicted_pu * (1.0 + rule.rel_tol)) + rule.abs_tol_pu
    return rule.rel_tol * abs(predicted_pu) + rule.abs_tol_pu


def floor_problems(plan, config: BenchConfig, fraction: float = FLOOR_FRACTION) -> list[str]:
    """The bench floor against the rule's acceptance half-width at this point (docstring 5)."""
    from hil.measurement import BASELINE
    from hil.measurement import _predict as predict_plan   # the prediction measure_point judges
    from hil.measurement import judged_prediction_pu

    try:
        op = config.model_point(plan.speed_rpm, plan.current_a, plan.current_angle_rad,
                                allow_beyond_voltage_limit=True)
        prediction = None if plan.source == BASELINE else predict_plan(plan, op)
    except InputError as exc:
        return [f"no prediction at this point: {exc}"]
    nameplate_nm = op.mean_torque_nm
    if prediction is None:
        predicted_pu, expected = 0.0, None
    else:
        scale = prediction.base_nm / nameplate_nm
        predicted_pu = judged_prediction_pu(prediction, plan.rule) * scale
        expected = (None if prediction.expected_range_pu is None else
                    tuple(v * scale for v in prediction.expected_range_pu))
    half_width_pu = acceptance_half_width_pu(plan.rule, predicted_pu, expected)
    floor_pu = resolvable_floor_nm(plan, config) / nameplate_nm
    what = "the bench's resolvable floor"
    if floor_pu <= fraction * half_width_pu:
        return []
    return [f"ripple not resolvable against {what}: {floor_pu * 100:.3g} % of the mean torque vs "
            f"{fraction:g} x the acceptance half-width {half_width_pu * 100:.3g} % (predicted "
            f"{predicted_pu * 100:.3g} %)"]
