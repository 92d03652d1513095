"""The questions a lab asks of the results database: history, compare two runs, trends.

Every number comes from the rows the records were indexed into (measured values and their
expanded uncertainties as the runs recorded them); nothing here predicts or re-measures.
"""

from __future__ import annotations

import json
import math

from hil.errors import InputError
from hil.results.capability import capability, control_chart, measured_yield
from hil.results.reproduction import reproduction
from hil.results.schema import point_orders, points, requirement_verdicts, runs

HISTORY_COLUMNS = ("record_id", "created_utc", "status", "statement", "dut_serial",
                   "drive_firmware", "motor_serial", "station", "operator", "n_tests",
                   "n_failed", "seal_sha256", "record_path")


def history(engine, *, dut: str | None = None, firmware: str | None = None,
            station: str | None = None, limit: int = 50) -> list[dict]:
    """Runs newest first, filtered by DUT serial, drive firmware and station."""
    from sqlalchemy import select

    query = select(*(runs.c[name] for name in HISTORY_COLUMNS))
    for column, value in ((runs.c.dut_serial, dut), (runs.c.drive_firmware, firmware),
                          (runs.c.station, station)):
        if value is not None:
            query = query.where(column == value)
    query = query.order_by(runs.c.created_utc.desc(), runs.c.record_id.desc()).limit(limit)
    with engine.connect() as connection:
        return [dict(row._mapping) for row in connection.execute(query)]


def resolve_run(connection, ref: str) -> str:
    """A record ID from an ID, a unique prefix of one, or a record folder path."""
    from pathlib import Path

    from sqlalchemy import select

    path = Path(ref)
    if (path / "record.json").exists():
        from hil.record import load_record

        record_id = load_record(path)["record_id"]
        if connection.execute(select(runs.c.record_id).where(
                runs.c.record_id == record_id)).first() is None:
            # an unindexed (or unsealed) folder is not an empty run with nothing to compare
            raise InputError(f"run {ref!r}: record {record_id} is not in the results database "
                             f"(a sealed record is added by 'hil db import {ref}')")
        return record_id
    found = list(connection.execute(select(runs.c.record_id).where(
        runs.c.record_id.like(ref.replace("%", "") + "%")).limit(3)).scalars())
    if ref in found:
        return ref
    if len(found) != 1:
        raise InputError(f"run {ref!r}: " + ("not in the results database" if not found else
                                             f"ambiguous ({', '.join(found)}, …)"))
    return found[0]


def _difference(a: float | None, ua: float | None, b: float | None, ub: float | None) -> dict:
    """b − a with U_d = √(U_a² + U_b²) (independent runs, same coverage factor)."""
    if None in (a, ua, b, ub):
        return {"a": a, "u_a": ua, "b": b, "u_b": ub, "difference": None, "u_difference": None,
                "changed": None}
    d = b - a
    ud = math.hypot(ua, ub)
    return {"a": a, "u_a": ua, "b": b, "u_b": ub, "difference": d, "u_difference": ud,
            "changed": abs(d) > ud}


def compare(engine, ref_a: str, ref_b: str) -> dict:
    """Matching points of two runs (same test id) side by side: pk-pk per unit of the nameplate
    torque and every order both analysed (amplitude, N·m; U = k·u with the point's coverage
    factor), each difference with U_d = √(U_a² + U_b²) and whether |d| > U_d. A test id measured
    at another operating point (speed, current, current angle) or injection in the two runs is
    listed in ``different_point`` with its differences, judged neither changed nor unchanged
    (``changed`` None): the difference is the point's, not the drive's. ``reproduction``:
    whether B reproduces A on the points either run judged (``hil.results.reproduction``)."""
    from sqlalchemy import select

    with engine.connect() as connection:
        id_a, id_b = resolve_run(connection, ref_a), resolve_run(connection, ref_b)
        pts = {rid: {r.test_id: r for r in connection.execute(
            select(points).where(points.c.record_id == rid))} for rid in (id_a, id_b)}
        orders: dict[str, dict] = {id_a: {}, id_b: {}}
        for row in connection.execute(select(point_orders).where(
                point_orders.c.record_id.in_([id_a, id_b]))):
            orders[row.record_id].setdefault(row.test_id, {})[row.order] = row
    a_points, b_points = pts[id_a], pts[id_b]
    matched = [tid for tid in a_points if tid in b_points]
    rows = []
    for tid in matched:
        pa, pb = a_points[tid], b_points[tid]
        entry = {"test_id": tid, "source": pa.source, "speed_rpm": pa.speed_rpm,
                 "current_a": pa.current_a, "injection": json.loads(pa.injection or "{}"),
                 "same_point": (pa.speed_rpm, pa.current_a, pa.current_angle_rad, pa.injection)
                 == (pb.speed_rpm, pb.current_a, pb.current_angle_rad, pb.injection),
                 "outcome_a": pa.outcome, "outcome_b": pb.outcome,
                 "pk_pk_pu": _difference(pa.pk_pk_pu, pa.pk_pk_u_pu, pb.pk_pk_pu, pb.pk_pk_u_pu),
                 "orders": []}
        oa, ob = orders[id_a].get(tid, {}), orders[id_b].get(tid, {})
        for order in sorted(set(oa) & set(ob)):
            ka, kb = pa.coverage_factor or 2.0, pb.coverage_factor or 2.0
            ua = ka * oa[order].amplitude_u_nm if oa[order].amplitude_u_nm is not None else None
            ub = kb * ob[order].amplitude_u_nm if ob[order].amplitude_u_nm is not None else None
            entry["orders"].append({"order": order, **_difference(
                oa[order].amplitude_nm, ua, ob[order].amplitude_nm, ub)})
        if not entry["same_point"]:     # not like for like: differences shown, not judged
            for diff in (entry["pk_pk_pu"], *entry["orders"]):
                diff["changed"] = None
        rows.append(entry)
    changed = [r["test_id"] for r in rows if r["pk_pk_pu"]["changed"]]
    unchanged = [r["test_id"] for r in rows if r["pk_pk_pu"]["changed"] is False]
    return {"run_a": id_a, "run_b": id_b, "points": rows, "changed": changed,
            "unchanged": unchanged,
            "not_comparable": [r["test_id"] for r in rows if r["same_point"]
                               and r["pk_pk_pu"]["changed"] is None],
            "different_point": [r["test_id"] for r in rows if not r["same_point"]],
            "only_in_a": sorted(set(a_points) - set(b_points)),
            "only_in_b": sorted(set(b_points) - set(a_points)),
            "orders_changed": [{"test_id": r["test_id"], "order": o["order"]} for r in rows
                               for o in r["orders"] if o["changed"]],
            "reproduction": reproduction(rows),
            "rule": "changed when |b - a| > U_d = sqrt(U_a^2 + U_b^2) (k = 2 each); "
                    "about 5 % of unchanged quantities exceed it by chance"}


def trend(engine, *, requirement: str | None = None, source: str | None = None,
          point: str | None = None, limit: int = 10_000) -> dict:
    """One observation per run (the newest ``limit`` runs, oldest first) for a requirement or a
    source's point, with the control chart, Cp/Cpk and the measured yield
    (``hil.results.capability``).

    Requirement: the run's verdict nearest its limit (the worst margin), accepted when every
    verdict of that requirement in the run was. Source: the measured pk-pk (per unit of the
    nameplate torque) at ``point`` (a test id; default the source's most measured one), limits
    the model verdict's tolerance zone, accepted when the point's test passed; only runs at the
    newest run's operating point, injection and motor serial (the others are counted in
    ``runs_at_other_points``: their prediction and zone differ). The fold to one
    row per run is done by the database (GROUP BY), so a fleet of 10,000 runs returns 10,000 rows.
    """
    if (requirement is None) == (source is None):
        raise InputError("give --requirement ID or --source NAME (one of them)")
    from sqlalchemy import case, func, select

    with engine.connect() as connection:
        if requirement is not None:
            rv = requirement_verdicts.c
            big = 1e300
            above = func.coalesce(rv.limit_max - rv.measured, big)
            below = func.coalesce(rv.measured - rv.limit_min, big)
            margin = case((above < below, above), else_=below)
            ok = case((rv.accepted.is_(True), 1), else_=0)
            where = (rv.requirement_id == requirement, rv.measured.is_not(None))
            worst = (select(rv.record_id, func.min(margin).label("margin"),
                            func.min(ok).label("ok"))
                     .where(*where).group_by(rv.record_id).subquery())
            query = (select(rv.record_id, rv.measured.label("value"),
                            rv.expanded_uncertainty.label("u"), rv.limit_min.label("lower"),
                            rv.limit_max.label("upper"), rv.unit, worst.c.ok,
                            runs.c.created_utc, runs.c.dut_serial)
                     .join(worst, (worst.c.record_id == rv.record_id)
                           & (worst.c.margin == margin))
                     .join(runs, runs.c.record_id == rv.record_id)
                     .where(*where))
            label = f"requirement {requirement}"
        else:
            if point is None:
                point = connection.execute(
                    select(points.c.test_id).where(points.c.source == source,
                                                   points.c.pk_pk_pu.is_not(None))
                    .group_by(points.c.test_id).order_by(func.count().desc(), points.c.test_id)
                    .limit(1)).scalar()
            pc = points.c
            query = (select(pc.record_id, pc.pk_pk_pu.label("value"), pc.pk_pk_u_pu.label("u"),
                            pc.lower_limit_pu.label("lower"), pc.upper_limit_pu.label("upper"),
                            case((pc.outcome == "passed", 1), else_=0).label("ok"),
                            runs.c.created_utc, runs.c.dut_serial, runs.c.motor_serial,
                            pc.speed_rpm, pc.current_a, pc.current_angle_rad, pc.injection)
                     .join(runs, runs.c.record_id == pc.record_id)
                     .where(pc.source == source, pc.test_id == point, pc.pk_pk_pu.is_not(None)))
            label = f"source {source}, point {point}"
        query = query.order_by(runs.c.created_utc.desc(), runs.c.record_id.desc())
        rows, seen, other_point, key = [], set(), 0, None
        for row in connection.execute(query):       # two verdicts of one run at the same
            if row.record_id in seen:               # margin: one observation
                continue
            seen.add(row.record_id)
            if source is not None:
                # one point's trend: the newest run's operating point, injection and motor;
                # the same test id measured elsewhere (another bench file) has another
                # prediction and tolerance zone, and is counted, not charted
                here = (row.motor_serial, row.speed_rpm, row.current_a, row.current_angle_rad,
                        row.injection)
                key = here if key is None else key
                if here != key:
                    other_point += 1
                    continue
            rows.append(row)
            if len(rows) == limit:
                break
        rows.reverse()
    if not rows:
        raise InputError(f"no measured value of {label} in the results database")
    obs = [{"record_id": r.record_id, "created_utc": r.created_utc, "dut_serial": r.dut_serial,
            "value": r.value, "u": r.u, "accepted": bool(r.ok), "lower": r.lower,
            "upper": r.upper} for r in rows]
    values = [o["value"] for o in obs]
    lowers = sorted(o["lower"] for o in obs if o["lower"] is not None)
    uppers = sorted(o["upper"] for o in obs if o["upper"] is not None)
    lower = float(lowers[len(lowers) // 2]) if lowers else None      # median: one limit
    upper = float(uppers[len(uppers) // 2]) if uppers else None
    return {"what": label, "requirement": requirement, "source": source, "point": point,
            "runs_at_other_points": other_point,
            "unit": rows[0].unit if requirement is not None else "pu of the nameplate torque",
            "observations": obs, "lower_limit": lower, "upper_limit": upper,
            "control_chart": control_chart(
                values, nonnegative=source is not None or rows[0].unit == "%"),
            "capability": capability(values, lower, upper),
            "measured_yield": measured_yield([o["accepted"] for o in obs])}
