"""PWM switching ripple (paper III-D, eqs 29-31, Fig. 9): ripple at the switching frequency whose
pk-pk within one PWM period has an order-6 envelope.

A torque transducer (≈ 1 kHz) cannot see it, so the DAQ samples the phase currents fast and the
analysis (hil.analysis.switching) estimates the air-gap torque T̂ = Σ e_x·i_x/ω_m from them, the
encoder angle and the nameplate EMF, then takes the largest pk-pk of T̂ within a PWM period per
unit of its mean.

Sampling: the DAQ gives at most its ``max_sample_rate_hz`` (200 kS/s on the simulated bench),
i.e. 5 to 20 samples per period at 40 to 10 kHz. At an integer multiple of f_pwm the samples sit
at the same few phases of every period and miss the ripple's corners (at 200 kHz and 20 kHz the
pk-pk reads about 30 % low). So the rate is derived from the speed and the PWM frequency at each
point (hil.analysis.switching.capture_settings): f_s = f_pwm·(n + q), never a multiple, so the
sample phases walk through the period within each analysis window of G periods
(equivalent-time sampling: ≈ 80 effective samples per period at 500 rpm, ≈ 20 at 1500 rpm on
Table I), with as many electrical revolutions (≤ 8, ≥ 4) as the DAQ buffer holds. A point the
DAQ cannot capture (fewer than 8 effective samples per period at any rate, e.g. 20 kHz at
3000 rpm on Table I, or a buffer too small for 4 revolutions) is not determinable here: skipped
with the reason, never judged. Reverse rotation is braking: the model takes the
forward-equivalent voltage phasor (hil.model.pwm_resolution.forward_phasor_peak_v).

Where the drive needs so little voltage (braking: i·R and the EMF nearly cancel) that the DAQ
puts fewer than ``MIN_ACTIVE_SAMPLES`` sample phases on the PWM period's active states, the
extremes can fall between the samples (``active_state_problem``): there a reading *below* the
model that does not pass is not determinable here; a pass stays a PASS and a reading above the
zone a FAIL (the sampling can only read low).

A point whose U (mostly the sampling-bias bound of few samples per period) takes more than half
of the tolerance zone's half-width (``RESOLVED_FRACTION``, the share the validity regions allow
the bench floor, hil.validity.FLOOR_FRACTION), and whose interval is not wholly inside the zone,
cannot tell a right drive from a wrong one: not determinable here (an interval wholly outside the
zone is a FAIL, one wholly inside a PASS). At U = 0.79 of the half-width a correct drive passes
only where the model is within 4 % of it (8-pole 48 V motor, 800 rpm / 15 A, 10 kHz: 0.0657 ±
0.012 pu against 0.0710 pu, zone ±0.0152: a guarded "conditional pass", which fails).
The ±20 % band and the slope's ±0.20 were checked out of sample (hil/model/README.md, "PWM and
word-length bands"; studies/pwm_calibration.py).

Decision rule, from the physics: what is measured is the *torque* ripple within a period under
the drive's centre-aligned SVPWM. hil.model's ``switched_torque`` form (with ``svpwm``) computes
exactly that — the torque path through the switching states of a period — under ideal switches,
neglecting only the fundamental's change within one period and the ripple's own resistive drop
(both well below 1 % at 500 rpm), so it is judged like the other exact closed forms
(``CLOSED_FORM_RULE``). The paper's eqs 30-31 give a different quantity: the *phase-current*
ripple 2·Δi at the phase-voltage zero crossing, taken equal to the per-unit torque ripple, with an
envelope that is largest at the zero crossings and zero 30° away. The torque ripple is the
current ripple's projection on the EMF direction: its envelope is nearly flat and peaks midway
between zero crossings. The paper's figure is recorded beside the verdict
(``prediction.extras.paper_pk_pk_pu``) for comparison, not judged.
"""

import pytest

from ripple_hil_testplans import conditions as c
from ripple_hil_testplans.sensitivity import SWEEP_EXCLUDED_NOTE, check_sensitivity

pytestmark = pytest.mark.ripple_source("pwm_switching")

#: Electrical revolutions per point when the DAQ buffer holds them; fewer (≥ MIN_REVOLUTIONS)
#: at low speed.
REVOLUTIONS = 8
MIN_REVOLUTIONS = 4
#: Envelope orders analysed: 6 (eqs 29-31) and its harmonics; the 3° windows give 120 envelope
#: points per electrical revolution (G from the speed), enough for order 24.
MAX_ORDER = 24
#: The prediction the plan judges against (module docstring).
PREDICTION = {"model": "switched_torque", "modulation": "svpwm"}


def loop_gain_per_period(config) -> float | None:
    """The drive's proportional current-loop gain per PWM period, g = K_p·T_s/L, from the loop the
    bench file states at the drive's own PWM frequency (ω_c·T_s for the continuous PI on the
    motor it was tuned on); taken to hold at every PWM frequency of the sweep (the loop retuned
    with the carrier, as the simulated drive does: its bandwidth is a fixed share of f_pwm).
    K_p is designed on the motor the drive's gains came from (``BenchConfig.loop_tuning``: its
    nameplate) and L is the winding's (the characterised motor): a winding whose L is 0.7 of
    its nameplate sees g/0.7. None: no loop stated."""
    from hil.model.dead_time import stated_loop_gains
    from hil.validity import injected_or_default

    drive, op = config.drive, config.operating_point
    if drive.current_loop_bandwidth_hz is None:
        return None
    pwm_hz = injected_or_default(c.point(op, "pwm_switching", {}, None), config,
                                 "pwm_frequency_hz")
    point = config.model_point(op.speed_rpm, op.current_a, op.current_angle_rad,
                               allow_beyond_voltage_limit=True)
    gains = stated_loop_gains(point, drive.current_loop_design, drive.current_loop_bandwidth_hz,
                              pwm_hz)
    return gains.proportional_v_per_a / (config.motor.phase_inductance_h * pwm_hz)


def prediction_params(config) -> dict:
    """The model's inputs at this bench: the switched-torque form, and the drive's current-ADC
    step (``conditions.CURRENT_ADC_STEP_A``) with its loop gain per period, which bound the ripple
    the ADC adds (the range's top; without a stated loop, an ideal ADC)."""
    gain = loop_gain_per_period(config)
    if gain is None:
        return dict(PREDICTION)
    return {**PREDICTION, "current_adc_step_a": c.CURRENT_ADC_STEP_A,
            "loop_gain_per_period": gain}
EXPECTATION = ("judged against the switched-circuit torque ripple of the drive's centre-aligned "
               "SVPWM (hil.model switched_torque; reverse rotation as braking). The paper's eqs "
               "30-31 give the phase-current ripple 2·Δi at the phase-voltage zero crossing and "
               "equate it to the torque ripple; the torque ripple (the current ripple's "
               "projection on the EMF) has a flatter envelope that peaks midway between zero "
               "crossings; the paper's figure is recorded for comparison only "
               "(prediction.extras.paper_pk_pk_pu). Order 6 is judged where the predicted "
               "envelope varies enough to be resolved (hil/model/README.md). The zone's top "
               "adds what the drive's current ADC can add (stated ADC step; the loop's gain per "
               "PWM period from the stated loop at the drive's own PWM frequency, taken to hold "
               "at every frequency of the sweep: the loop retuned with the carrier)")


#: The fewest sample phases the DAQ puts on the active states of a PWM period (the steep segments
#: whose ends are the within-period extremes) for the measurement to find those extremes: the
#: model's ``active_fraction_at_peak`` × the capture's effective samples per period. Braking,
#: where the drive needs a few per cent of V_dc, the plan read 0.41-0.71 of the twin's own ripple
#: while the model held it (the 14-pole 48 V motor at -500 rpm / 20 A, 10/20 kHz; -800 rpm /
#: 15 A, 20 kHz). Set on the plan's own decisions over a calibration set (Table I, 8- and 14-pole
#: 48 V motors): its wrong rejections had at most 1.74 phases there, rounded up; the holdout
#: (10- and 12-pole) had none at any count (``studies/switching_sampling.py``; hil/model/README.md,
#: "PWM switching: active states the DAQ cannot sample").
MIN_ACTIVE_SAMPLES = 1.8


#: The largest share of the predicted switching ripple the drive's ADC bound may take for the
#: point to be judged: the zone's top, (pk + d)·1.2 + 0.002, then stays below 1.8× the model +
#: 0.002 pu, so a drive switching at half the PWM frequency (2× the ripple) still fails. Derived
#: from that defect, not from readings: braking at low current the bound is several times the
#: model (the 10- and 14-pole motors at −250 rpm / 10 A), where such a drive passed a zone that
#: reached 4-7× the model (review h-25).
ADC_MAX_SHARE = 0.5


def adc_problem(config, injection) -> str | None:
    """Why the drive's ADC can add too much for this point to be judged, or None."""
    from hil.model import predict

    op = config.operating_point
    point = config.model_point(op.speed_rpm, op.current_a, op.current_angle_rad)
    prediction = predict("pwm_switching", point, pwm_frequency_hz=injection["pwm_frequency_hz"],
                         **prediction_params(config))
    dither = prediction.extras["adc_dither_pu"]
    if dither <= ADC_MAX_SHARE * prediction.pk_pk_pu:
        return None
    return (f"the drive's current ADC can add up to {dither:.2g} pu to the within-period pk-pk "
            f"(step {c.CURRENT_ADC_STEP_A:.3g} A, loop gain {loop_gain_per_period(config):.3g} "
            f"per period), more than {ADC_MAX_SHARE:g} x the predicted switching ripple "
            f"{prediction.pk_pk_pu:.2g} pu at {op.speed_rpm:g} rpm / {op.current_a:g} A: a "
            "drive at half the PWM frequency would read inside the zone")


def active_state_problem(config, injection, settings) -> str | None:
    """Why the DAQ's sample phases cannot find this point's within-period extremes, or None."""
    from hil.model import predict

    op = config.operating_point
    point = config.model_point(op.speed_rpm, op.current_a, op.current_angle_rad)
    prediction = predict("pwm_switching", point, pwm_frequency_hz=injection["pwm_frequency_hz"],
                         **prediction_params(config))
    fraction = prediction.extras["active_fraction_at_peak"]
    samples = fraction * settings.effective_samples_per_period
    if samples >= MIN_ACTIVE_SAMPLES:
        return None
    period_us = 1e6 / injection["pwm_frequency_hz"]
    return (f"the active states last {fraction * period_us:.2g} µs of the {period_us:.3g} µs PWM "
            f"period at the ripple's largest angle ({op.speed_rpm:g} rpm / {op.current_a:g} A, "
            f"modulation index {prediction.extras['modulation_index']:.3f}) and the DAQ's "
            f"{settings.effective_samples_per_period:.3g} effective samples per period put "
            f"{samples:.2f} sample phases on them, fewer than {MIN_ACTIVE_SAMPLES:g}: the "
            "within-period extremes can fall between the samples, so the ripple can read low")


def reads_low(verdict) -> bool:
    """Whether a verdict's reading lies below the prediction: the only side a sampling that
    misses the extremes can err on (a reading above it stays judged; the zone's middle would
    not do, since the ADC dither bound lifts only the zone's top)."""
    return verdict is not None and verdict.measured_pk_pk_pu < verdict.predicted_pk_pk_pu


def capture(config, injection):
    """The DAQ rate and revolutions at the bench's point (module docstring), or why the DAQ cannot
    capture it (a string)."""
    from ripple_hil_drivers.daq_register_map import load_register_map

    from hil.analysis.switching import capture_settings

    device = load_register_map(config.daq.register_map).device
    return capture_settings(config.operating_point.speed_rpm, config.motor.pole_pairs,
                            injection["pwm_frequency_hz"],
                            max_sample_rate_hz=float(device["max_sample_rate_hz"]),
                            buffer_samples=int(device["buffer_capacity_samples"]),
                            max_order=MAX_ORDER, revolutions=REVOLUTIONS,
                            min_revolutions=MIN_REVOLUTIONS)


def plan(config, injection):
    settings = capture(config, injection)
    if isinstance(settings, str):
        # not determinable here (the test skips before measuring): a point the DAQ can hold, so
        # that the pre-flight checks the rest of the plan
        from hil.analysis.switching import CaptureSettings
        from ripple_hil_drivers.daq_register_map import load_register_map

        device = load_register_map(config.daq.register_map).device
        elec_hz = abs(config.operating_point.speed_rpm) * config.motor.pole_pairs / 60.0
        rate = min(float(device["max_sample_rate_hz"]),
                   0.9 * int(device["buffer_capacity_samples"]) * elec_hz / 2.25)
        settings = CaptureSettings(rate, 2, 1, 0.0)
    return c.point(config.operating_point, "pwm_switching", injection, c.CLOSED_FORM_RANGE_RULE,
                   analysis="switching", sample_rate_hz=settings.sample_rate_hz,
                   revolutions=settings.revolutions, max_order=MAX_ORDER,
                   prediction_params=prediction_params(config), expectation=EXPECTATION)


@pytest.mark.parametrize("injection", c.PWM_SWITCHING_SWEEP, ids=c.sweep_id)
def test_pwm_switching(measure, bench, record, injection):
    from hil.outcome_kinds import not_determinable

    settings = capture(bench.config, injection)
    if isinstance(settings, str):
        pytest.skip(not_determinable(f"pwm_switching: {settings}"))
    swamped = adc_problem(bench.config, injection)
    if swamped:
        pytest.skip(not_determinable(f"pwm_switching: {swamped}"))
    unsampled = active_state_problem(bench.config, injection, settings)
    outcome = measure(plan(bench.config, injection))
    if unsampled and not outcome.passed and reads_low(outcome.verdict):
        # a reading known to be biased low: recorded, but not one of the sweep's slope points
        notes = (record.test(outcome.test_id) or {}).get("notes") or []
        record.update_test(outcome.test_id, notes=[
            *notes, SWEEP_EXCLUDED_NOTE + "read low where the DAQ cannot sample the active states"])
        pytest.skip(not_determinable(f"pwm_switching: read below the model where {unsampled}"))
    reason = unresolved(outcome.verdict)
    if reason:
        pytest.skip(not_determinable(f"pwm_switching: {reason}"))
    assert outcome.passed, outcome.summary()


#: U may take at most this share of the zone's half-width for an interval that straddles a zone
#: edge to be judged: the share the validity regions allow the bench floor.
from hil.validity import FLOOR_FRACTION as RESOLVED_FRACTION  # noqa: E402


def unresolved(verdict) -> str | None:
    """Why this verdict cannot tell a right drive from a wrong one, or None: the interval
    measured ± U straddles a zone edge (wholly inside: PASS; wholly outside: FAIL) and U (the
    guard band) takes more than RESOLVED_FRACTION of the zone's half-width on that edge's side
    of the prediction (the ADC dither bound lifts only the top: the half-widths differ).
    Where this happens: few effective samples per PWM period (a window of one period at high
    electrical speed) and a ripple small against the sampling bias bound."""
    if verdict is None or verdict.guarded_pass or verdict.signature_ok is False:
        return None
    predicted, measured = verdict.predicted_pk_pk_pu, verdict.measured_pk_pk_pu
    u = verdict.expanded_uncertainty_pu
    low, high = measured - u, measured + u
    straddled = ([predicted - verdict.lower_limit_pu]
                 if low <= verdict.lower_limit_pu <= high else []) + \
                ([verdict.upper_limit_pu - predicted]
                 if low <= verdict.upper_limit_pu <= high else [])
    if straddled and u > RESOLVED_FRACTION * min(straddled):
        return (f"measured {verdict.measured_pk_pk_pu:.4g} ± {u:.2g} pu against the zone "
                f"[{verdict.lower_limit_pu:.4g}, {verdict.upper_limit_pu:.4g}]: U is more than "
                f"{RESOLVED_FRACTION:g} of the zone's half-width and the interval straddles its "
                "edge (sampling bias of few samples per PWM period)")
    return None


def test_pwm_switching_sensitivity(record):
    """The sweep's measured ripple scales with the injection as the model says (slope 1)."""
    result = check_sensitivity(record, "pwm_switching", c.CLOSED_FORM_RULE.rel_tol)
    assert result["accepted"], result["statement"]
