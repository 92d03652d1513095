"""First schema: runs, points (pk-pk with U, prediction, verdict), requirement verdicts.

Revision ID: 0001
"""
import sqlalchemy as sa
from alembic import op

revision = "0001"
down_revision = None


def upgrade() -> None:
    op.create_table(
        "runs",
        sa.Column("record_id", sa.String(64), primary_key=True),
        sa.Column("seal_sha256", sa.String(64), nullable=False),
        sa.Column("record_path", sa.Text, nullable=False),
        sa.Column("status", sa.String(32), nullable=False),
        sa.Column("statement", sa.String(32), nullable=False),
        sa.Column("statement_reason", sa.Text),
        sa.Column("created_utc", sa.String(32), nullable=False),
        sa.Column("finished_utc", sa.String(32)),
        sa.Column("software_version", sa.String(64)),
        sa.Column("git_sha", sa.String(64)),
        sa.Column("simulated", sa.Boolean, nullable=False),
        sa.Column("sim_defects", sa.Text),
        sa.Column("station", sa.String(200)),
        sa.Column("operator", sa.String(200)),
        sa.Column("dut_serial", sa.String(200)),
        sa.Column("drive_serial", sa.String(200)),
        sa.Column("drive_firmware", sa.String(200)),
        sa.Column("motor_serial", sa.String(200)),
        sa.Column("n_tests", sa.Integer, nullable=False),
        sa.Column("n_failed", sa.Integer, nullable=False),
        sa.Column("indexed_utc", sa.String(32), nullable=False),
    )
    op.create_index("ix_runs_dut", "runs", ["dut_serial"])
    op.create_index("ix_runs_firmware", "runs", ["drive_firmware"])
    op.create_index("ix_runs_station", "runs", ["station"])
    op.create_index("ix_runs_created", "runs", ["created_utc"])
    op.create_table(
        "points",
        sa.Column("id", sa.Integer, primary_key=True, autoincrement=True),
        sa.Column("record_id", sa.String(64),
                  sa.ForeignKey("runs.record_id", ondelete="CASCADE"), nullable=False),
        sa.Column("test_id", sa.Text, nullable=False),
        sa.Column("source", sa.String(64)),
        sa.Column("kind", sa.String(32)),
        sa.Column("outcome", sa.String(16), nullable=False),
        sa.Column("speed_rpm", sa.Float),
        sa.Column("current_a", sa.Float),
        sa.Column("current_angle_rad", sa.Float),
        sa.Column("injection", sa.Text),
        sa.Column("mean_torque_nm", sa.Float),
        sa.Column("pk_pk_pu", sa.Float),
        sa.Column("pk_pk_u_pu", sa.Float),
        sa.Column("coverage_factor", sa.Float),
        sa.Column("predicted_pk_pk_pu", sa.Float),
        sa.Column("decision", sa.String(32)),
        sa.Column("lower_limit_pu", sa.Float),
        sa.Column("upper_limit_pu", sa.Float),
        sa.UniqueConstraint("record_id", "test_id", name="uq_points_record_test"),
    )
    op.create_index("ix_points_source", "points", ["source"])
    op.create_table(
        "requirement_verdicts",
        sa.Column("id", sa.Integer, primary_key=True, autoincrement=True),
        sa.Column("record_id", sa.String(64),
                  sa.ForeignKey("runs.record_id", ondelete="CASCADE"), nullable=False),
        sa.Column("test_id", sa.Text, nullable=False),
        sa.Column("requirement_id", sa.String(100), nullable=False),
        sa.Column("quantity", sa.String(64)),
        sa.Column("unit", sa.String(16)),
        sa.Column("measured", sa.Float),
        sa.Column("expanded_uncertainty", sa.Float),
        sa.Column("limit_min", sa.Float),
        sa.Column("limit_max", sa.Float),
        sa.Column("rule", sa.String(32)),
        sa.Column("decision", sa.String(32)),
        sa.Column("accepted", sa.Boolean),
        sa.Column("speed_rpm", sa.Float),
        sa.Column("current_a", sa.Float),
    )
    op.create_index("ix_requirement_verdicts_req", "requirement_verdicts", ["requirement_id"])


def downgrade() -> None:
    op.drop_table("requirement_verdicts")
    op.drop_table("points")
    op.drop_table("runs")
