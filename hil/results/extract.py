"""A sealed run record → the rows that index it (pure: no database here).

Every value is read from the record as the run wrote it; the run's overall statement comes from
the one derivation every sink uses (``reports/statement.py``: ``overall_statement``, design.md
§7), given the record's integrity problems. Nothing is re-derived from the captures and nothing
is predicted here.
"""

from __future__ import annotations

import json
from datetime import datetime, timezone

from hil.record import BAD_OUTCOMES


def _num(value) -> float | None:
    return float(value) if isinstance(value, (int, float)) and not isinstance(value, bool) \
        else None


def _instrument(record: dict, role: str) -> dict:
    return next((i for i in record.get("instruments") or [] if i.get("role") == role), {}) or {}


def dut_identity(record: dict, dut_serial: str | None = None) -> dict:
    """The DUT serial (``dut_serial`` given at indexing, else the record's ``dut`` section —
    ``hil run --dut-serial`` or the station's scan, ``hil.dut`` — else an older record's
    ``run.dut_serial`` or station ``unit``, else the drive's), how it was stated and checked
    against the drive, the drive's CiA 301 identity (0x1018 vendor-ID, product code, revision,
    serial number, as read; the bench file's serial when it states one) and firmware (0x100A),
    and the motor serial (bench file)."""
    drive = _instrument(record, "drive")
    identity = drive.get("identity") or {}
    queried = identity.get("serial_number", identity.get("serial"))
    drive_serial = drive.get("serial_number") or (str(queried) if queried is not None else None)
    motor = (((record.get("bench") or {}).get("loaded") or {}).get("motor") or {})
    run = record.get("run") or {}
    dut = record.get("dut") or {}
    own = dut.get("drive_identity") or {}
    recorded = dut.get("serial") or run.get("dut_serial") or \
        (record.get("unit") or {}).get("serial_number")
    return {"dut_serial": dut_serial or recorded or drive_serial,
            "drive_serial": drive_serial,
            "drive_firmware": identity.get("firmware") or identity.get("software_version"),
            "motor_serial": motor.get("serial_number") or None,
            "dut_stated_by": "hil db --dut-serial" if dut_serial else dut.get("stated_by"),
            "dut_serial_check": dut.get("check"), "dut_serial_override": dut.get("override"),
            "drive_vendor_id": _int(own.get("vendor", identity.get("vendor"))),
            "drive_product_code": _int(own.get("product", identity.get("product"))),
            "drive_revision": _int(own.get("revision", identity.get("revision"))),
            "drive_serial_number": _int(own.get("serial", queried))}


def _int(value) -> int | None:
    return int(value) if isinstance(value, int) and not isinstance(value, bool) else None


def run_row(record: dict, record_path: str, seal_sha256: str, statement,
            dut_serial: str | None = None) -> dict:
    """The ``runs`` row; ``statement``: ``overall_statement(record, problems)``."""
    lab = record.get("lab") or {}
    run = record.get("run") or {}
    software = record.get("software") or {}
    tests = record.get("tests") or []
    return {
        "record_id": record["record_id"], "seal_sha256": seal_sha256,
        "record_path": record_path, "status": record["status"],
        "statement": statement.overall, "statement_reason": statement.reason,
        "created_utc": record["created_utc"], "finished_utc": record.get("finished_utc"),
        "software_version": software.get("version"), "git_sha": software.get("git_sha"),
        "simulated": bool((record.get("bench") or {}).get("simulated")),
        "sim_defects": json.dumps(record.get("sim_defects") or {}, sort_keys=True),
        "station": run.get("station") or lab.get("name"),
        "operator": run.get("operator") or lab.get("operator"),
        **dut_identity(record, dut_serial),
        "n_tests": len(tests),
        "n_failed": sum(1 for t in tests if t.get("outcome") in BAD_OUTCOMES),
        "indexed_utc": datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
    }


def point_rows(record: dict) -> list[dict]:
    """One ``points`` row per test entry (every outcome, measured or not)."""
    rows = []
    for test in record.get("tests") or []:
        op = test.get("operating_point") or {}
        measured = test.get("measured") or {}
        uncertainty = test.get("uncertainty") or {}
        verdict = test.get("verdict") or {}
        prediction = test.get("prediction") or {}
        pk_pk = _num(verdict.get("measured_pk_pk_pu"))
        if pk_pk is None:
            pk_pk = _num(measured.get("pk_pk_pu"))
        u = _num(verdict.get("expanded_uncertainty_pu"))
        if u is None:
            u = _num(uncertainty.get("expanded_pu"))
        rows.append({
            "record_id": record["record_id"], "test_id": test["test_id"],
            "source": test.get("source"), "kind": test.get("kind"),
            "outcome": test.get("outcome") or "not run",
            "speed_rpm": _num(op.get("speed_rpm")), "current_a": _num(op.get("current_a")),
            "current_angle_rad": _num(op.get("current_angle_rad")),
            "injection": json.dumps(test.get("injection") or {}, sort_keys=True),
            "mean_torque_nm": _num(measured.get("mean_torque_nm")),
            "pk_pk_pu": pk_pk, "pk_pk_u_pu": u,
            "coverage_factor": _num(uncertainty.get("coverage_factor")),
            "predicted_pk_pk_pu": _num(verdict.get("predicted_pk_pk_pu",
                                                   prediction.get("pk_pk_pu"))),
            "decision": verdict.get("decision"),
            "lower_limit_pu": _num(verdict.get("lower_limit_pu")),
            "upper_limit_pu": _num(verdict.get("upper_limit_pu")),
        })
    return rows


def order_rows(record: dict) -> list[dict]:
    """One ``point_orders`` row per analysed order of each measured point (``top_orders``)."""
    rows = []
    for test in record.get("tests") or []:
        for order in (test.get("measured") or {}).get("top_orders") or []:
            if _num(order.get("order")) is None:
                continue
            rows.append({"record_id": record["record_id"], "test_id": test["test_id"],
                         "order": float(order["order"]),
                         "amplitude_nm": _num(order.get("amplitude_nm")),
                         "amplitude_u_nm": _num(order.get("amplitude_u_nm")),
                         "phase_rad": _num(order.get("phase_rad"))})
    return rows


def requirement_rows(record: dict) -> list[dict]:
    """One ``requirement_verdicts`` row per requirement judged on a point."""
    from ripple_hil_reports.statement import accepted

    rows = []
    for test in record.get("tests") or []:
        op = test.get("operating_point") or {}
        for verdict in test.get("requirements") or []:
            limit = verdict.get("limit") or {}
            rows.append({"record_id": record["record_id"], "test_id": test["test_id"],
                         "requirement_id": str(verdict.get("id")),
                         "quantity": verdict.get("quantity"), "unit": verdict.get("unit"),
                         "measured": _num(verdict.get("measured")),
                         "expanded_uncertainty": _num(verdict.get("expanded_uncertainty")),
                         "limit_min": _num(limit.get("min")),
                         "limit_max": _num(limit.get("max")),
                         "rule": verdict.get("rule"), "decision": verdict.get("decision"),
                         "accepted": accepted(verdict),
                         "speed_rpm": _num(op.get("speed_rpm")),
                         "current_a": _num(op.get("current_a"))})
    return rows


def diagnosis_rows(record: dict) -> list[dict]:
    """One ``diagnosis_estimates`` row per parameter of the record's ``diagnosis`` section."""
    diagnosis = record.get("diagnosis") or {}
    return [{"record_id": record["record_id"], "name": str(p.get("name")),
             "unit": p.get("unit"), "estimate": _num(p.get("estimate")),
             "standard_uncertainty": _num(p.get("standard_uncertainty")),
             "identifiable": bool(p.get("identifiable"))}
            for p in diagnosis.get("parameters") or [] if p.get("name")]
