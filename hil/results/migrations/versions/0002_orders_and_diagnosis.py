"""Order spectra of each point (for ``hil compare`` orders) and diagnosis estimates of each run
(for ``hil yield --from-db``). Runs indexed under 0001 keep their rows and get no orders or
estimates rows (the record folder still has them).

Revision ID: 0002
Revises: 0001
"""
import sqlalchemy as sa
from alembic import op

revision = "0002"
down_revision = "0001"


def upgrade() -> None:
    op.create_table(
        "point_orders",
        sa.Column("id", sa.Integer, primary_key=True, autoincrement=True),
        sa.Column("record_id", sa.String(64),
                  sa.ForeignKey("runs.record_id", ondelete="CASCADE"), nullable=False),
        sa.Column("test_id", sa.Text, nullable=False),
        sa.Column("order", sa.Float, nullable=False),
        sa.Column("amplitude_nm", sa.Float),
        sa.Column("amplitude_u_nm", sa.Float),
        sa.Column("phase_rad", sa.Float),
    )
    op.create_index("ix_point_orders_record", "point_orders", ["record_id"])
    op.create_table(
        "diagnosis_estimates",
        sa.Column("id", sa.Integer, primary_key=True, autoincrement=True),
        sa.Column("record_id", sa.String(64),
                  sa.ForeignKey("runs.record_id", ondelete="CASCADE"), nullable=False),
        sa.Column("name", sa.String(100), nullable=False),
        sa.Column("unit", sa.String(16)),
        sa.Column("estimate", sa.Float),
        sa.Column("standard_uncertainty", sa.Float),
        sa.Column("identifiable", sa.Boolean),
    )
    op.create_index("ix_diagnosis_estimates_name", "diagnosis_estimates", ["name"])


def downgrade() -> None:
    op.drop_table("diagnosis_estimates")
    op.drop_table("point_orders")
