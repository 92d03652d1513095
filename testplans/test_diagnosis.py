"""Diagnosis: measure the drive as it is (nothing injected) at the designed operating points, then
attribute its ripple to the sources (sensor offsets, gain mismatch, dead time, encoder, motor) and
state the calibration that would remove it (hil.diagnosis; design in diagnosis_design.py).

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
from hil.diagnosis import diagnose, spectra_from_captures
from hil.diagnosis.bench_setup import check_setup_known, setup_from_bench_dict
from hil.measurement import PointPlan
from hil.record import capture_path
from ripple_hil_testplans import diagnosis_design as design

pytestmark = pytest.mark.ripple_source("diagnosis")

POINTS = design.design_points()
#: test id of each measured point, filled as the points run (module order: points first)
_MEASURED: dict = {}


@pytest.mark.parametrize("point", POINTS, ids=[p.label.replace(" ", "") for p in POINTS])
def test_diagnosis_point(measure, point):
    plan = PointPlan(source="diagnosis", injection={}, speed_rpm=point.speed_rpm,
                     current_a=point.current_a, current_angle_rad=point.current_angle_rad,
                     revolutions=design.REVOLUTIONS_ELEC, max_order=64,
                     sample_rate_hz=design.SAMPLE_RATE_HZ, settle_s=design.SETTLE_S, rule=None,
                     kind="diagnosis",
                     expectation="nothing injected: measured for the ripple diagnosis (no model "
                                 "verdict)")
    outcome = measure(plan)
    _MEASURED[point] = outcome.test_id


def test_diagnosis(bench, record):
    missing = [p.label for p in POINTS if p not in _MEASURED]
    assert not missing, f"diagnosis needs every designed point; not measured: {missing}"
    pairs = []
    for point in POINTS:
        entry = record.test(_MEASURED[point])
        path = capture_path(record.path, (entry.get("capture") or {}).get("file"))
        assert path is not None, f"{point.label}: the record names no capture"
        pairs.append((Capture.load(path), {"current_a": point.current_a,
                                           "current_angle_rad": point.current_angle_rad,
                                           "label": point.label}))
    setup, class_pct = setup_from_bench_dict(bench.config.to_dict())
    spectra = spectra_from_captures(pairs, max_mech_order=design.MAX_MECH_ORDER)
    result = diagnose(spectra, setup=setup, transducer_class_pct=class_pct)
    result.notes.extend(check_setup_known(setup))
    record.set_section("diagnosis", result.to_dict())
    print("\n" + result.table())
    unseparated = [w for w in result.weak if set(CONTROLLER) & set(w["parameters"])]
    assert not unseparated, f"the design cannot separate: {unseparated}"
    unstated = unstated_parameters(result)
    assert not unstated, f"the diagnosis cannot state: {'; '.join(unstated)}"


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
