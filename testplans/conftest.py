"""Session set-up of the test plans: the decision rules and the plans' validity regions
(hil.validity) are written to the record before the first point is measured (they are agreed
before measuring, ISO/IEC 17025 §7.1.3)."""

from dataclasses import asdict

import pytest

from hil import validity
from ripple_hil_testplans import conditions as c


@pytest.fixture(scope="session", autouse=True)
def agreed_decision_rules(record):
    record.set_decision_rule({
        "name": "ILAC-G8:2009 guarded acceptance; guard band = k·U (k = 2) of the measured pk-pk",
        "ripple_definition": "pk-pk of the synchronous average over whole electrical revolutions "
                             "per unit of the measured mean torque",
        "closed_form": asdict(c.CLOSED_FORM_RULE),
        "bound": asdict(c.BOUND_RULE),
        "derived_estimate": asdict(c.DERIVED_ESTIMATE_RULE),
        "baseline": asdict(c.BASELINE_RULE),
        "baseline_ceiling_pu": c.BASELINE_CEILING_PU,
        "validity_regions": {name: region.to_dict() for name, region in validity.REGIONS.items()},
        "validity_floor": f"{validity.FLOOR_COUNTS:g} counts of the torque reading's resolution "
                          f"may take at most {validity.FLOOR_FRACTION:g} of a rule's acceptance "
                          "half-width; a point outside its region is not determinable",
        "validity_voltage_headroom": "the peak phase voltage a point needs (steady phasor at the "
                                     "signed speed, the dead time's loss, the current injected "
                                     "sensor errors make the loop drive) within (V_dc/√3)·(1 − "
                                     "4·T_d·f_pwm), also at every corner of the characterised "
                                     "R, L, Ke ± U (k = 2)",
    })


@pytest.fixture(autouse=True)
def not_determinable_here(request, agreed_decision_rules, bench):
    """Skip a point outside its plan's validity region (hil.validity), with its reason, after the
    decision rules are in the record; nothing is sent to the drive. The region is that of the
    bench as characterised (``bench.config``) where the characterisation changed it, else the
    pre-flight's decision on the file as stated; either way the voltage headroom must hold
    within the measured motor's U (fixtures/preflight.py ``refusal_on_bench``)."""
    from hil.outcome_kinds import not_determinable
    from ripple_hil_fixtures.preflight import refusal_on_bench

    from hil.characterisation.stage import motor_bounds_of

    stated = getattr(bench, "stated_config", None) or bench.config
    reason = refusal_on_bench(request.node, stated, bench.config, motor_bounds_of(bench))
    if reason is not None:
        pytest.skip(not_determinable(reason))
