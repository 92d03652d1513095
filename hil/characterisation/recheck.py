"""Is the characterisation still the bench? The winding measured again before each plan
(issue 29 Build 4: a characterisation that goes stale during the run is repeated).

Copper's resistance rises about 0.39 %/K: a winding that warms through a run drifts away from
the R the stage measured at its start, and every prediction that reads R (the loop's response,
the dead time's current clamping, the validity regions' voltage) with it. Before each plan the
winding capture of the stage (``hil.characterisation.stage``: the drive regulating the same
operating point's current, the terminal voltage, the back EMF measured at the start) is taken
again and R and L identified from it (``identify.winding``); a terminal voltage beyond the DAQ's
range is tried at the stage's slower speeds (R and L do not depend on the speed). Where the new R
or L differs from the one the characterisation holds by more than their combined U (k = 2, in
quadrature: the DAQ gain term both share is counted twice, so the test is conservative), the
characterisation is repeated for the winding — R and L replaced, the bench as measured
(``bench.config``) built again — before the plan's predictions and validity regions are
decided; ``Characterisation.used`` still keeps a stated value the new measurement confirms.
ψ, the loop and the transducer are not measured again (the magnet's EMF moves −0.1 %/K, ten
times less than R). The value is the winding *before* the plan: a winding that warms or cools
during a plan is seen by the next recheck, not within the plan.

Every recheck is in the record's ``characterisation_rechecks`` section (the plan it preceded,
both values, the decision; "not rechecked" with the reason where no capture could measure it,
and then the plan's predictions use the held values), its capture saved raw as
``characterisation-recheck-<n>-<plan>``.
"""

from __future__ import annotations

import math
from dataclasses import replace

from hil.characterisation.identify import Identified, winding

#: The record section listing the rechecks.
SECTION = "characterisation_rechecks"
#: Electrical revolutions of a recheck's capture (the stage's 16 halved: a run checks before
#: every plan; the type-A u of R grows by √2, from ~0.1 % of R at the shipped bench's point)
REVOLUTIONS = 8
_KEYS = ("phase_resistance_ohm", "phase_inductance_h")
#: The decisions a recheck records.
CONFIRMED, RECHARACTERISED, NOT_RECHECKED = "confirmed", "re-characterised", "not rechecked"


def drifted(before: Identified, now: Identified) -> bool:
    """``now`` differs from ``before`` beyond their combined U (k = 2)."""
    return abs(now.value - before.value) > math.hypot(before.expanded, now.expanded)


def _winding_capture(bench, record, name, point, pole_pairs):
    """The winding capture at ``point``, else at the stage's slower speeds; the capture, or the
    reason there is none."""
    from hil.characterisation.stage import SLOWER_SPEED_FACTORS, capture_plan, voltage_capture

    reasons = []
    for factor in (1.0,) + SLOWER_SPEED_FACTORS:
        at = replace(point, speed_rpm=point.speed_rpm * factor)
        capture = voltage_capture(bench, record, f"{name}-{abs(at.speed_rpm):.0f}rpm",
                                  capture_plan(at, pole_pairs, enabled=True,
                                               revolutions=REVOLUTIONS), pole_pairs)
        if not isinstance(capture, str):
            return capture
        reasons.append(capture)
    return "; ".join(reasons)


def recheck_winding(bench, record, plan: str, history: list) -> dict | None:
    """Measure R and L again before ``plan``; replace them (and ``bench.config``) where they
    drifted. Returns the recorded entry (also appended to ``history`` and written to the record's
    section), or None where the stage identified no winding to recheck."""
    from hil.characterisation.stage import VOLTAGE_SKEW_BOUND_S

    result = getattr(bench, "characterisation", None)
    stated = getattr(bench, "stated_config", None)
    if result is None or stated is None or result.emf is None or result.point is None \
            or any(result.get(key) is None for key in _KEYS):
        return None
    pole_pairs = bench.config.motor.pole_pairs
    capture = _winding_capture(bench, record, f"characterisation-recheck-{len(history) + 1}-{plan}",
                               result.point, pole_pairs)
    entry = {"before_plan": plan}
    if isinstance(capture, str):
        entry.update(decision=NOT_RECHECKED, reason=capture,
                     predictions_use=result.used(stated))
    else:
        fresh = winding(capture, result.emf, pole_pairs, skew_bound_s=VOLTAGE_SKEW_BOUND_S,
                        gain_u_rel=stated.daq_gain_u_rel())
        moved = [item.name for item in fresh if drifted(result.get(item.name), item)]
        entry.update({item.name: {"unit": item.unit, "held": _value(result.get(item.name)),
                                  "measured": _value(item)} for item in fresh})
        entry["method"] = "the stage's winding capture again (identify.winding), same point"
        if moved:
            result = result.with_winding(*fresh)
            bench.characterisation = result
            bench.config = result.measured_config(stated)
            entry.update(decision=RECHARACTERISED, drifted=moved)
        else:
            entry.update(decision=CONFIRMED)
        entry["predictions_use"] = result.used(stated)
    history.append(entry)
    record.set_section(SECTION, {"rechecks": history})
    return entry


def _value(item: Identified) -> dict:
    return {"value": item.value, "U_k2": item.expanded}
