"""Diagnosis: measure the drive as it is (nothing injected) at the designed operating points, then
attribute its ripple to the sources (sensor offsets, gain mismatch, dead time, encoder, motor) and
state the calibration that would remove it (hil.diagnosis; design in diagnosis_design.py).

Standard additions (issue 23 item 1, hil.diagnosis.additions): the design's addition points
inject one KNOWN addition each through the drive's injection knobs (a sensor offset, sensor a's
gain, the dead time); ``test_diagnosis_by_additions`` calibrates each source's transfer in situ
from them, estimates the same parameters relative to the additions, and fails when an addition
is not linear over its size, a parameter cannot be stated, a calibrated transfer contradicts the
forward model of the same addition (the injection does not apply what it says where it says —
wrong sensor, scale or sign — or the stated loop does not describe the drive), or the two routes
disagree (family-wise 99.9 % over the parameters both state). A transfer whose model the
addition's plan's validity region refuses at the point (hil.validity; e.g. the dead time at
+1000 rpm, 20 A on a 2-pole 24 V motor: no voltage headroom) is recorded "not compared:
<reason>", neither passed nor failed. The additions, transfers, linearity checks and cross-checks go into the record's
``diagnosis`` section under ``additions``. Every injection is removed after its point
(hil.measurement restores and reads back the knobs on every path, failures included).

The points carry no model verdict (nothing is injected, so there is no prediction to judge); they
are recorded with ``kind = "diagnosis"`` and outcome "measured, no verdict" (design.md §9), unless
one of the run's requirements judges them. The last test fits the forward models to all of them
and stores the result as the record's ``diagnosis`` section; it fails when a point is missing,
when the design cannot separate the controller's parameters (then the design, not the drive, is
wrong), or when the fit cannot state a controller parameter: not identifiable, or an estimate
or standard uncertainty that is not a finite number (:func:`unstated_parameters`).
"""

import math

import pytest

from hil.capture import Capture
from hil.characterisation.stage import motor_bounds_of
from hil.diagnosis import diagnose, spectra_from_captures
from hil.diagnosis import additions
from hil.diagnosis.bench_setup import check_setup_known, setup_from_bench_dict
from hil.measurement import PointPlan
from hil.outcome_kinds import not_determinable
from hil.record import capture_path
from ripple_hil_testplans import diagnosis_design as design

pytestmark = pytest.mark.ripple_source("diagnosis")

POINTS = design.design_points()
ADDITION_POINTS = design.addition_points()
REPEAT_POINTS = design.repeat_points()
#: test id of each measured point, filled as the points run (module order: points first)
_MEASURED: dict = {}
#: the fit's result and the bench setup, for the additions test
_FIT: dict = {}


@pytest.mark.parametrize("point", POINTS + ADDITION_POINTS + REPEAT_POINTS,
                         ids=[p.label.replace(" ", "")
                              for p in POINTS + ADDITION_POINTS + REPEAT_POINTS])
def test_diagnosis_point(measure, point):
    expectation = ("nothing injected: measured again after the additions, for their "
                   "between-capture reproducibility (no model verdict)" if point.repeat else
                   "nothing injected: measured for the ripple diagnosis (no model verdict)"
                   if point.addition is None else
                   f"known addition {point.addition[0]} = {point.addition[1]:g} (standard "
                   "additions: calibrates its source's transfer in situ; no model verdict here, "
                   "the transfer is judged in test_diagnosis_by_additions)")
    plan = PointPlan(source="diagnosis", injection=point.injection, speed_rpm=point.speed_rpm,
                     current_a=point.current_a, current_angle_rad=point.current_angle_rad,
                     revolutions=design.REVOLUTIONS_ELEC, max_order=64,
                     sample_rate_hz=design.SAMPLE_RATE_HZ, settle_s=design.SETTLE_S, rule=None,
                     kind="diagnosis", expectation=expectation)
    outcome = measure(plan)
    _MEASURED[point] = outcome.test_id


def _pairs(record, points) -> list:
    missing = [p.label for p in points if p not in _MEASURED]
    assert not missing, f"diagnosis needs every designed point; not measured: {missing}"
    pairs = []
    for point in points:
        entry = record.test(_MEASURED[point])
        path = capture_path(record.path, (entry.get("capture") or {}).get("file"))
        assert path is not None, f"{point.label}: the record names no capture"
        pairs.append((Capture.load(path), point.operating_point()))
    return pairs


def test_diagnosis(bench, record):
    pairs = _pairs(record, POINTS)
    setup, class_pct = setup_from_bench_dict(bench.config.to_dict(),
                                             loop_tuning=bench.config.loop_tuning)
    spectra = spectra_from_captures(pairs, max_mech_order=design.MAX_MECH_ORDER)
    result = diagnose(spectra, setup=setup, transducer_class_pct=class_pct)
    result.notes.extend(check_setup_known(setup))
    record.set_section("diagnosis", result.to_dict())
    _FIT.update(result=result, setup=setup, class_pct=class_pct, spectra=spectra)
    print("\n" + result.table())
    unseparated = [w for w in result.weak if set(CONTROLLER) & set(w["parameters"])]
    assert not unseparated, f"the design cannot separate: {unseparated}"
    unstated = unstated_parameters(result)
    assert not unstated, f"the diagnosis cannot state: {'; '.join(unstated)}"


#: The plan whose validity region (hil.validity.REGIONS) holds the forward model of each addition.
ADDITION_SOURCES = {"addition_ia_offset_a": "dc_offset", "addition_ib_offset_a": "dc_offset",
                    "addition_gain_a_pu": "gain_mismatch", "addition_dead_time_s": "dead_time"}


def model_refusal(config, bounds=None):
    """``refusal(transfer)`` for :func:`additions.compare_transfers_with_models`: why the
    addition's plan's validity region (hil.validity: direction, speed, voltage headroom with the
    largest addition applied and its current — the pre-flight's limits — and within the measured
    motor's ``bounds``, ``hil.characterisation.stage.motor_bounds_of``) refuses its model at the
    transfer's point, or None. The bench-floor limit is not applied: it bounds a pk-pk verdict,
    while a transfer carries its own measured uncertainty."""
    from hil.validity import guarded_voltage_problems, problems

    def refusal(transfer):
        plan = PointPlan(source=ADDITION_SOURCES[transfer["addition"]],
                         injection={additions.INJECTION_KNOBS[transfer["addition"]]:
                                    max(transfer["sizes"], key=abs)},
                         speed_rpm=transfer["speed_rpm"], current_a=transfer["current_a"],
                         current_angle_rad=transfer["current_angle_rad"],
                         revolutions=design.REVOLUTIONS_ELEC, max_order=64,
                         sample_rate_hz=design.SAMPLE_RATE_HZ, settle_s=design.SETTLE_S,
                         rule=None, kind="diagnosis")
        found = problems(plan, config) or guarded_voltage_problems(plan, config, bounds or {})
        return (f"the {plan.source} model's validity region refuses the point: "
                f"{'; '.join(found)}") if found else None
    return refusal


def test_diagnosis_by_additions(bench, record):
    """Standard additions: every parameter stated (linear over its addition, separable), every
    calibrated transfer consistent with the forward model of its addition, and the estimates
    consistent with the fit's (two independent routes)."""
    assert _FIT, "the fit (test_diagnosis) did not run"
    lacking = _lacking_knobs(bench.config)
    if lacking:
        pytest.skip(not_determinable("standard additions: " + "; ".join(
            f"the drive under test has no {knob}" for knob in lacking)))
    pairs = _pairs(record, ADDITION_POINTS + REPEAT_POINTS)
    points = {(p.speed_rpm, p.current_a) for p in ADDITION_POINTS}
    bases = [additions.with_addition(s, {}) for s, point in zip(_FIT["spectra"], POINTS)
             if (point.speed_rpm, point.current_a) in points]
    added = additions.spectra_with_additions(pairs, max_mech_order=design.MAX_MECH_ORDER)
    result = additions.diagnose_by_additions(bases + added, setup=_FIT["setup"])
    refusal = model_refusal(bench.config, motor_bounds_of(bench))
    models = additions.compare_transfers_with_models(result, _FIT["setup"], _FIT["class_pct"],
                                                     refusal=refusal)
    routes = additions.compare_with_fit(result, _FIT["result"])
    section = _FIT["result"].to_dict()
    section["additions"] = result.to_dict() | {
        "points": [{"label": p.label, "injection": p.injection}
                   for p in ADDITION_POINTS + REPEAT_POINTS],
        "transfer_vs_model": models, "versus_fit": routes}
    record.set_section("diagnosis", section)
    print("\n" + result.table())
    # the dead time alone may be "not linear over the addition": its torque is not
    # proportional to T_d near zero (hil.diagnosis.additions); or "not separable" from a motor
    # term at its mechanical order (on a 10-pole motor electrical order 6 is mechanical order
    # 30, where cogging sits: the design cannot tell them apart, the reason names the remedy).
    # Both are reported, and the fit's average-model value stands. Offsets and gain enter
    # linearly at orders 1 and 2: not linear or not separable there is a fault.
    problems = [f"{e['name']}: {e['reason'] or 'no finite uncertainty'}"
                for e in result.estimates if not e["stated"]
                and not (e["name"] in DEAD_TIME_NAMES
                         and e["reason"].startswith(DEAD_TIME_DESIGN_LIMITS))]
    # a transfer whose model's region refuses the point is recorded "not compared", not judged
    problems += [m["statement"] for m in models if m["compared"] and not m["agrees"]]
    problems += [r["statement"] for r in routes if r["compared"] and not r["agrees"]]
    missing = [name for name in REQUIRED if result.value(name) is None]
    problems += [f"{name}: not stated by the additions" for name in missing
                 if not any(p.startswith(name) for p in problems)]
    assert not problems, "standard additions: " + "; ".join(problems)


def _lacking_knobs(config) -> list[str]:
    """The knobs the additions need that the drive under test cannot inject (its profile)."""
    from ripple_hil_drivers.drive_profile import profile_for

    profile = profile_for(config.drive)
    return sorted({knob for point in ADDITION_POINTS for knob, value in point.injection.items()
                   if profile.lacks(knob, value)})


DEAD_TIME_NAMES = ("dead_time_us",)
#: What the additions may say of the dead time without it being a fault of the drive (above).
DEAD_TIME_DESIGN_LIMITS = ("not linear over the addition", "not separable from")


#: The controller's parameters the diagnosis exists to state (hil.diagnosis.parameters); the
#: offsets and the gain difference are always fitted, the dead time unless it is a nuisance.
CONTROLLER = ("ia_offset_a", "ib_offset_a", "gain_k_diff", "dead_time_us")
REQUIRED = CONTROLLER[:3]


def unstated_parameters(result) -> list[str]:
    """The controller parameters the fit does not state: missing (offsets, gain difference),
    not identifiable, or with an estimate or standard uncertainty that is not a finite number
    (a standard uncertainty must also be > 0: a fit that claims zero uncertainty has not
    propagated its noise)."""
    fitted = {item.name: item for item in result.parameters}
    problems = [f"{name}: not fitted" for name in REQUIRED if name not in fitted]
    for name in CONTROLLER:
        item = fitted.get(name)
        if item is None:
            continue
        if not item.identifiable:
            problems.append(f"{name}: not identifiable")
        elif not (math.isfinite(item.estimate) and math.isfinite(item.standard_uncertainty)
                  and item.standard_uncertainty > 0):
            problems.append(f"{name}: {item.estimate!r} ± {item.standard_uncertainty!r} "
                            f"{item.unit} (standard uncertainty) is not a finite statement")
    return problems
