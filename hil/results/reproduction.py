"""Does run B reproduce run A on the points either run judged? (``hil compare``; issue 29: a
bench against its own twin, ``hil characterize --write-twin``).

A **judged point** is a test that gave a verdict (outcome passed or failed) in A or B. Its
compared figure is the one its verdict is stated on: the pk-pk per unit of the nameplate torque
with the expanded U (k = 2) each run recorded for it; the difference d = b − a is within U when
|d| ≤ U_d = √(U_a² + U_b²) (``hil.results.queries.compare``). B reproduces A when every judged
point with a figure in both runs is within U and no verdict differs. A judged test without such
a figure (a sensitivity fit over its plan's points, a characterisation check), measured at
another operating point or injection, or whose figure is not a torque ripple (U_d beyond 100 %
of the nameplate torque: the angle reference, measured with the drive disabled) is listed as not
comparable, with why; it never counts as reproduced.

The analysed orders' amplitudes are not part of the statement: their recorded U is the
revolution scatter alone (no transducer class, no resolution), so a few per cent of unchanged
orders exceed it by chance and small systematic differences (a twin whose loop bandwidth was
measured within its U but not exactly) exceed it too; ``compare`` lists them beside.
"""

from __future__ import annotations

#: Record outcomes that carry a verdict (hil.outcome_kinds: "measured, no verdict" and
#: "not determinable" judge nothing; an error or a skip gave no verdict either).
JUDGED_OUTCOMES = ("passed", "failed")

#: A pk-pk difference or U_d beyond this (per unit of the nameplate torque: 100 %) is not on the
#: scale of a torque ripple (e.g. the angle reference, measured with the drive disabled, whose
#: U_d was ±1·10⁷ %).
OFF_SCALE_PU = 1.0


def off_scale(point: dict) -> bool:
    """True when ``point``'s compared pk-pk (a ``compare`` row) is off a torque ripple's scale."""
    d = point["pk_pk_pu"]
    return abs(d["difference"]) > OFF_SCALE_PU or (d["u_difference"] or 0.0) > OFF_SCALE_PU


def is_judged(point: dict) -> bool:
    """A ``compare`` row whose test gave a verdict in run A or run B."""
    return point["outcome_a"] in JUDGED_OUTCOMES or point["outcome_b"] in JUDGED_OUTCOMES


def _not_comparable(point: dict) -> str | None:
    if not point["same_point"]:
        return "measured at another operating point or injection in the two runs"
    if point["pk_pk_pu"]["difference"] is None:
        return "no pk-pk with U in both runs (a fit over its plan's points, or a check)"
    if off_scale(point):
        return "not a torque ripple (U_d or |d| beyond 100 % of the nameplate torque)"
    return None


def reproduction(points: list[dict]) -> dict:
    """The judged points of ``compare``'s rows: ``within_u``, ``beyond_u`` (test ids),
    ``not_comparable`` (test id → why), ``verdicts_differ`` ({test_id, outcome_a, outcome_b}),
    ``plans_beyond_u`` (the sources of the points beyond U or whose verdict differs),
    ``reproduced`` and a one-line ``statement``."""
    judged = [p for p in points if is_judged(p)]
    within, beyond, not_comparable = [], [], {}
    for point in judged:
        why = _not_comparable(point)
        if why is not None:
            not_comparable[point["test_id"]] = why
        elif point["pk_pk_pu"]["changed"]:
            beyond.append(point["test_id"])
        else:
            within.append(point["test_id"])
    differ = [{"test_id": p["test_id"], "outcome_a": p["outcome_a"], "outcome_b": p["outcome_b"]}
              for p in judged if p["outcome_a"] != p["outcome_b"]]
    flagged = set(beyond) | {d["test_id"] for d in differ}
    plans = sorted({p["source"] or "?" for p in judged if p["test_id"] in flagged})
    compared = len(within) + len(beyond)
    reproduced = compared > 0 and not flagged
    if reproduced:
        statement = (f"reproduced within U on every judged point ({compared} of {compared} "
                     f"compared: |d| <= U_d; verdicts the same)")
    elif not flagged:
        statement = "not stated: no judged point has a pk-pk with U in both runs"
    else:
        parts = [f"{len(beyond)} of {compared} judged point(s) differ beyond U_d"] if beyond \
            else []
        parts += [f"{len(differ)} verdict(s) differ"] if differ else []
        statement = "NOT reproduced: " + "; ".join(parts) + f" (plans: {', '.join(plans)})"
    if not_comparable:
        statement += f"; {len(not_comparable)} judged test(s) not comparable (listed)"
    return {"within_u": within, "beyond_u": beyond, "not_comparable": not_comparable,
            "verdicts_differ": differ, "plans_beyond_u": plans, "reproduced": reproduced,
            "statement": statement}
