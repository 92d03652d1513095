"""The results database's tables (SQLAlchemy 2 Core), as of the newest migration.

The database is an index of sealed run records (design.md §10): the record folder stays the truth
and every ``runs`` row carries the record's seal hash (``record.sha256``). Rows are only ever
inserted, one record per transaction, keyed on the record ID, so an index is either all there or
absent. Units are SI or per unit of the nameplate mean torque K_t·I·cos φ (``_pu``), as in the
record; expanded uncertainties (``_u_``) are at the coverage factor the record states (k = 2).

The schema grows by Alembic migrations (``hil/results/migrations``): 0001 is the first schema
(runs, points, requirement verdicts); 0002 added the order spectra of each point and the diagnosis
estimates of each run; 0003 made every string column that carries a value of the record unbounded
``Text`` (an outcome such as "measured, no verdict" did not fit PostgreSQL's ``varchar(16)``; the
record, not the schema, decides what a value may be). 0004 added the unit's traceability (how its serial was
stated and checked, the drive's own 0x1018 identity). Only the record ID (the record writer's fixed
``YYYYMMDDTHHMMSSZ-xxxxxx``), the seal hash and the time of indexing keep a length. Edit a table here only together with a new
migration.
"""

from __future__ import annotations

from sqlalchemy import (BigInteger, Boolean, Column, Float, ForeignKey, Index, Integer, MetaData,
                        String, Table, Text, UniqueConstraint)

metadata = MetaData()

runs = Table(
    "runs", metadata,
    Column("record_id", String(64), primary_key=True),
    Column("seal_sha256", String(64), nullable=False),       # record.sha256 at indexing
    Column("record_path", Text, nullable=False),
    Column("status", Text, nullable=False),
    Column("statement", Text, nullable=False),          # overall: PASS … INVALID
    Column("statement_reason", Text),
    Column("created_utc", Text, nullable=False),
    Column("finished_utc", Text),
    Column("software_version", Text),
    Column("git_sha", Text),
    Column("simulated", Boolean, nullable=False),
    Column("sim_defects", Text),                              # JSON, "{}" for none
    Column("station", Text),                           # the lab / bench name
    Column("operator", Text),
    Column("dut_serial", Text),                        # --dut-serial, else the drive's
    Column("drive_serial", Text),
    Column("drive_firmware", Text),
    Column("motor_serial", Text),
    # ---- added by migration 0004: the unit's traceability (hil.dut)
    Column("dut_stated_by", Text),                            # --dut-serial, station scan, …
    Column("dut_serial_check", Text),                         # match, not compared, …
    Column("dut_serial_override", Text),                      # the recorded reason, if any
    Column("drive_vendor_id", BigInteger),                    # CiA 301 0x1018:01 as read
    Column("drive_product_code", BigInteger),                 # 0x1018:02
    Column("drive_revision", BigInteger),                     # 0x1018:03
    Column("drive_serial_number", BigInteger),                # 0x1018:04
    Column("n_tests", Integer, nullable=False),
    Column("n_failed", Integer, nullable=False),              # failed or errored
    Column("indexed_utc", String(32), nullable=False),
)
Index("ix_runs_dut", runs.c.dut_serial)
Index("ix_runs_firmware", runs.c.drive_firmware)
Index("ix_runs_station", runs.c.station)
Index("ix_runs_created", runs.c.created_utc)

points = Table(
    "points", metadata,
    Column("id", Integer, primary_key=True, autoincrement=True),
    Column("record_id", String(64), ForeignKey("runs.record_id", ondelete="CASCADE"),
           nullable=False),
    Column("test_id", Text, nullable=False),
    Column("source", Text),
    Column("kind", Text),
    Column("outcome", Text, nullable=False),
    Column("speed_rpm", Float),
    Column("current_a", Float),
    Column("current_angle_rad", Float),
    Column("injection", Text),                                # canonical JSON
    Column("mean_torque_nm", Float),
    Column("pk_pk_pu", Float),                                # measured, of the nameplate torque
    Column("pk_pk_u_pu", Float),                              # its expanded uncertainty
    Column("coverage_factor", Float),
    Column("predicted_pk_pk_pu", Float),
    Column("decision", Text),                           # model verdict (ILAC-G8 zone)
    Column("lower_limit_pu", Float),                          # the verdict's tolerance zone
    Column("upper_limit_pu", Float),
    UniqueConstraint("record_id", "test_id", name="uq_points_record_test"),
)
Index("ix_points_source", points.c.source)

requirement_verdicts = Table(
    "requirement_verdicts", metadata,
    Column("id", Integer, primary_key=True, autoincrement=True),
    Column("record_id", String(64), ForeignKey("runs.record_id", ondelete="CASCADE"),
           nullable=False),
    Column("test_id", Text, nullable=False),
    Column("requirement_id", Text, nullable=False),
    Column("quantity", Text),
    Column("unit", Text),
    Column("measured", Float),
    Column("expanded_uncertainty", Float),
    Column("limit_min", Float),
    Column("limit_max", Float),
    Column("rule", Text),
    Column("decision", Text),
    Column("accepted", Boolean),
    Column("speed_rpm", Float),
    Column("current_a", Float),
)
Index("ix_requirement_verdicts_req", requirement_verdicts.c.requirement_id)

# ---- added by migration 0002
point_orders = Table(
    "point_orders", metadata,
    Column("id", Integer, primary_key=True, autoincrement=True),
    Column("record_id", String(64), ForeignKey("runs.record_id", ondelete="CASCADE"),
           nullable=False),
    Column("test_id", Text, nullable=False),
    Column("order", Float, nullable=False),                   # electrical order
    Column("amplitude_nm", Float),
    Column("amplitude_u_nm", Float),                          # type-A standard uncertainty
    Column("phase_rad", Float),
)
Index("ix_point_orders_record", point_orders.c.record_id)

diagnosis_estimates = Table(
    "diagnosis_estimates", metadata,
    Column("id", Integer, primary_key=True, autoincrement=True),
    Column("record_id", String(64), ForeignKey("runs.record_id", ondelete="CASCADE"),
           nullable=False),
    Column("name", Text, nullable=False),              # ia_offset_a, gain_k_diff, …
    Column("unit", Text),
    Column("estimate", Float),
    Column("standard_uncertainty", Float),
    Column("identifiable", Boolean),
)
Index("ix_diagnosis_estimates_name", diagnosis_estimates.c.name)

#: Tables in insertion order (children after ``runs``).
TABLES = (runs, points, requirement_verdicts, point_orders, diagnosis_estimates)
