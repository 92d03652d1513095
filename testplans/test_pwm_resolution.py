"""PWM pulse-width resolution (paper III-D, eqs 27-28): the duty register's step ΔV/V = 1/2^(n-1)
with n the counter bits; here the counter's counts per half period set the step.

Eq 28 is the torque change of one voltage step with the voltage applied open loop; the drive
closes a current loop around the PWM, which turns the step into a disturbance it rejects. Both
eq 28 and the closed-loop bound are one-sided (a drive ignoring the injection meets them), so the
plan judges against the derived duty-quantisation model of hil.model.pwm_resolution (two-sided,
its own stated range; simple acceptance — see conditions.DERIVED_RANGE_SIMPLE_RULE); the bound
and eq 28 are recorded. There is no pk-pk scaling-exponent check: its U (±0.7 to ±1.6 at every
point of the calibration and holdout sets, hil/model/README.md) is always wider than any useful
tolerance, so it could never judge (it was "not determinable" at every point, leaving the source
NOT DETERMINED on every run); the noise check below judges the scaling with the counter.

Neither catches a drive that applies the counter scaled (1.5× or 0.7× the commanded counts):
the pk-pk of a ripple that is not synchronous with the rotor has U ≈ its value, the derived
model is known only within [⅓, 3]×, and a constant factor keeps the scaling. The noise check
does: the RMS of the torque left after the synchronous average (hil.analysis.nonsync, relative
U of a few %) at each counter, the bench's own floor (a reference point at the drive's default
counter, no verdict) removed in quadrature, against the quantised-loop noise model of
hil.model.pwm_noise (its own range from the model's spread against the simulated drive).
"""

import math

import pytest

from ripple_hil_testplans import conditions as c

pytestmark = pytest.mark.ripple_source("pwm_resolution")

#: The drive's default counter (the EDS default of pwm_period_counts): the reference point whose
#: non-synchronous RMS is the bench's own floor (its modelled quantisation noise, ~1/19 of the
#: 128-count point's, is taken out of it first).
NOISE_REFERENCE_COUNTS = 2000
#: Analysed orders of the points (the synchronous average the noise statistic removes).
MAX_ORDER = 48


def plan(config, injection):
    if config.torque.bandwidth_hz is None:       # refused at pre-flight, nothing sent
        from hil.errors import InputError

        raise InputError("pwm_resolution: the bench file's [torque] bandwidth_hz (the torque "
                         "output's -3 dB bandwidth, from the transducer's data sheet) is needed "
                         "by the noise check's model")
    # a loop delay the noise model cannot represent (e.g. a double-update drive's 0.75 PWM
    # periods) makes the point not determinable here: hil.validity.loop_delay_problems
    # the derived form averages over as many revolutions as the point captures
    # captured at least at conditions.MIN_RATE_PER_TRANSDUCER_BANDWIDTH × the stated transducer
    # bandwidth: at 2 kHz the 2-pole 24 V motor at 250 rpm read 1.4-4.5× this model (folded
    # quantisation content), the sweep's scale 1.58-1.99
    return c.transducer_limited_rate(c.point(
        config.operating_point, "pwm_resolution", injection, c.DERIVED_RANGE_SIMPLE_RULE,
        revolutions=c.PWM_RESOLUTION_REVOLUTIONS,
        prediction_params={"model": "derived", "max_order": 48,
                           "revolutions_averaged": c.PWM_RESOLUTION_REVOLUTIONS,
                           **c.current_loop(config)},
        expectation="judged against the derived duty-quantisation model through the drive's "
                    "current loop (two-sided, its own stated range); the closed-loop bound and "
                    "the paper's open-loop eq 28 are recorded for comparison only"), config)


@pytest.mark.parametrize("injection", c.PWM_RESOLUTION_SWEEP, ids=c.sweep_id)
def test_pwm_resolution(measure, bench, injection):
    outcome = measure(plan(bench.config, injection))
    assert outcome.passed, outcome.summary()


#: The sweep's geometric-mean measured/predicted pk-pk (issue 30 item 4; provenance:
#: hil/model/README.md "PWM resolution: the sweep's scale"): calibration set (Table I, 4 points)
#: 0.618-0.764, band = that range ÷/× 1.5. Holdout (8- and 2-pole motors, 7 runs) 0.565-0.783.
#: A model 2x too large reads 0.28-0.39 and fails at every point of both sets, which the
#: per-point [1/3, 3]x range could not do.
SCALE_BAND = (0.41, 1.15)
#: Sweep points the scale check needs (of PWM_RESOLUTION_SWEEP's three).
SCALE_MIN_POINTS = 2


def sweep_scale(record) -> tuple[float | None, list]:
    """(geometric mean of measured/predicted pk-pk over the judged sweep points, their ratios)."""
    ratios = [t["verdict"]["measured_pk_pk_pu"] / t["verdict"]["predicted_pk_pk_pu"]
              for t in record.tests if t.get("source") == "pwm_resolution"
              and t.get("verdict") and t["verdict"].get("predicted_pk_pk_pu")]
    if len(ratios) < SCALE_MIN_POINTS or min(ratios) <= 0:
        return None, ratios
    return math.exp(sum(math.log(r) for r in ratios) / len(ratios)), ratios


def test_pwm_resolution_scale(record):
    """The sweep's measured pk-pk over the derived model's, geometric mean over the counters,
    within SCALE_BAND: the per-point range is [⅓, 3]× (one point's U is of the order of its
    value), the sweep's mean is far tighter and fails a model 2× too large."""
    from hil.outcome_kinds import not_determinable

    scale, ratios = sweep_scale(record)
    if scale is None:
        pytest.skip(not_determinable(f"pwm_resolution scale: {len(ratios)} judged point(s) of "
                                     f"the sweep; the scale needs {SCALE_MIN_POINTS}"))
    low, high = SCALE_BAND
    statement = (f"geometric mean of measured/predicted pk-pk {scale:.3f} over "
                 f"{len(ratios)} counters ({', '.join(f'{r:.3f}' for r in ratios)}) vs "
                 f"[{low:g}, {high:g}]")
    record.set_section("pwm_resolution_scale", {"scale": scale, "ratios": ratios,
                                                "band": list(SCALE_BAND),
                                                "accepted": low <= scale <= high,
                                                "statement": statement})
    assert low <= scale <= high, f"pwm_resolution scale: {statement}"


def test_pwm_resolution_noise_reference(measure, bench):
    """The bench's own non-synchronous floor: the drive's default counter, no model verdict
    (after the sweep, so that the sweep's points run as they did before the noise check).
    Nothing judges it: recorded "measured, no verdict" (hil.outcome_kinds.MEASURED), never a
    pass; a requirement that applies to it still judges it."""
    # at the sweep's capture rate (conditions.transducer_limited_rate): the floor it gives is
    # removed from theirs
    outcome = measure(c.transducer_limited_rate(c.point(
        bench.config.operating_point, "pwm_resolution",
        {"pwm_period_counts": NOISE_REFERENCE_COUNTS}, None,
        revolutions=c.PWM_RESOLUTION_REVOLUTIONS, max_order=MAX_ORDER,
        expectation="reference for the noise check: the bench's own non-synchronous floor (no "
                    "model verdict)"), bench.config))
    assert outcome.passed, outcome.summary()


def noise_decision(value_pu: float, expanded_pu: float, low_pu: float, high_pu: float) -> str:
    """One counter's decision against the noise model's range: simple acceptance (ILAC-G8, w = 0),
    as for the derived models' own ranges (conditions.DERIVED_RANGE_SIMPLE_RULE): the range's
    factors were set from the simulated drive's *measured* values, whose scatter (this U) they
    already hold, so guarding by U again would count it twice — a "conditional pass" (inside the
    range, U reaching past its edge) is a pass. Outside the range: "fail", unless U is more than
    FLOOR_FRACTION of the range's half-width and the interval reaches into the range — then the
    measurement cannot tell (the floor-removed RMS of a counter whose noise is near the bench's
    own floor): "not determinable". An interval wholly outside is always a fail."""
    from hil.validity import FLOOR_FRACTION

    if low_pu <= value_pu <= high_pu:
        return "pass"
    reaches = value_pu + expanded_pu >= low_pu and value_pu - expanded_pu <= high_pu
    if reaches and expanded_pu > FLOOR_FRACTION * (high_pu - low_pu) / 2.0:
        return "not determinable"
    return "fail"


def test_pwm_resolution_noise(record, bench):
    """Each counter's non-synchronous torque RMS, floor removed, lies in the quantised-loop
    noise model's range (simple acceptance, :func:`noise_decision`)."""
    from hil.analysis.nonsync import floor_removed, nonsynchronous_rms_of_capture
    from hil.capture import Capture
    from hil.measurement import DEFAULT_PWM_FREQUENCY_HZ
    from hil.model.pwm_noise import predict_noise
    from hil.outcome_kinds import MEASURED

    config = bench.config
    entries = {t["injection"].get("pwm_period_counts"): t for t in record.tests
               if t.get("source") == "pwm_resolution" and t.get("capture")
               and t.get("outcome") in ("passed", "failed", MEASURED)}
    if NOISE_REFERENCE_COUNTS not in entries or len(entries) < 2:
        pytest.skip("pwm_resolution noise: the reference point and at least one counter must "
                    f"have been measured (got counters {sorted(entries)})")
    if config.torque.bandwidth_hz is None:
        pytest.skip("pwm_resolution noise: the bench file's [torque] bandwidth_hz is needed by "
                    "the noise model")
    loop = c.current_loop(config)
    pole_pairs = config.motor.pole_pairs

    def measured_and_model(entry):
        capture = Capture.load(record.path / entry["capture"]["file"])
        stat = nonsynchronous_rms_of_capture(capture, pole_pairs=pole_pairs,
                                             max_order=MAX_ORDER)
        point = entry["operating_point"]
        op = config.model_point(point["speed_rpm"], point["current_a"],
                                point["current_angle_rad"])
        model = predict_noise(op, entry["injection"]["pwm_period_counts"],
                              pwm_frequency_hz=entry["injection"].get(
                                  "pwm_frequency_hz", DEFAULT_PWM_FREQUENCY_HZ),
                              transducer_bandwidth_hz=config.torque.bandwidth_hz,
                              revolutions=stat.revolutions, max_order=MAX_ORDER, **loop)
        base = op.mean_torque_nm
        return stat.rms_nm / base, stat.rms_u_nm / base, model

    ref_pu, ref_u, ref_model = measured_and_model(entries.pop(NOISE_REFERENCE_COUNTS))
    floor_pu = math.sqrt(max(ref_pu ** 2 - ref_model.rms_pu ** 2, 0.0))
    rows, accepted = [], True
    for counts in sorted(entries):
        raw_pu, raw_u, model = measured_and_model(entries[counts])
        # sqrt(raw² − floor²) and its U (k = 2), both standard uncertainties propagated
        value, expanded = floor_removed(raw_pu, raw_u, ref_pu, ref_u, ref_model.rms_pu)
        low, high = model.expected_range_pu
        decision = noise_decision(value, expanded, low, high)
        accepted &= decision != "fail"
        rows.append({"pwm_period_counts": counts, "measured_rms_pu": value,
                     "expanded_uncertainty_pu": expanded, "raw_rms_pu": raw_pu,
                     "predicted_rms_pu": model.rms_pu, "limits_pu": [low, high],
                     "ratio": value / model.rms_pu, "decision": decision,
                     "white_noise_rms_pu": model.white_noise_rms_pu,
                     "assumptions": list(model.assumptions)})
    statement = "; ".join(
        f"C={r['pwm_period_counts']}: {100 * r['measured_rms_pu']:.3f} % ± "
        f"{100 * r['expanded_uncertainty_pu']:.3f} vs {100 * r['predicted_rms_pu']:.3f} % "
        f"[{100 * r['limits_pu'][0]:.3f}, {100 * r['limits_pu'][1]:.3f}] → {r['decision']}"
        for r in rows)
    judged = [r for r in rows if r["decision"] != "not determinable"]
    record.set_section("pwm_resolution_noise", {
        "rule": "simple acceptance against the model's range; outside with U > "
                "FLOOR_FRACTION of its half-width and reaching into it: not determinable",
        "statistic": "hil.analysis.nonsync: RMS of the torque less its synchronous average "
                     f"(orders 0..{MAX_ORDER}), per unit of K_t·I·cos φ",
        "floor_rms_pu": floor_pu, "reference_rms_pu": ref_pu,
        "reference_model_rms_pu": ref_model.rms_pu,
        "reference_counts": NOISE_REFERENCE_COUNTS, "points": rows,
        "accepted": accepted if judged else None, "statement": statement})
    assert accepted, f"pwm_resolution noise: {statement} (floor {100 * floor_pu:.3f} %)"
    if not judged:
        from hil.outcome_kinds import not_determinable

        pytest.skip(not_determinable(f"pwm_resolution noise: no counter resolved: {statement} "
                                     f"(floor {100 * floor_pu:.3f} %)"))
