"""The unit's traceability (``hil.dut``): how its serial was stated (``--dut-serial``, the
station's scan) and checked against the drive, a recorded override, and the drive's own CiA 301
identity (0x1018 vendor-ID, product code, revision, serial number). Runs indexed before keep
NULL there (their records hold no ``dut`` section).

Revision ID: 0004
Revises: 0003
"""
import sqlalchemy as sa
from alembic import op

revision = "0004"
down_revision = "0003"

COLUMNS = (("dut_stated_by", sa.Text), ("dut_serial_check", sa.Text),
           ("dut_serial_override", sa.Text), ("drive_vendor_id", sa.BigInteger),
           ("drive_product_code", sa.BigInteger), ("drive_revision", sa.BigInteger),
           ("drive_serial_number", sa.BigInteger))


def upgrade() -> None:
    with op.batch_alter_table("runs") as batch:
        for name, kind in COLUMNS:
            batch.add_column(sa.Column(name, kind()))


def downgrade() -> None:
    with op.batch_alter_table("runs") as batch:
        for name, _ in COLUMNS:
            batch.drop_column(name)
