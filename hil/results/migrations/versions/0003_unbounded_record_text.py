"""Every string column that carries a value of the record becomes unbounded ``Text``: the outcome
"measured, no verdict" (20 characters) did not fit ``points.outcome varchar(16)`` and PostgreSQL
refused to index every run with a diagnosis, ripple-map or PWM-resolution point (SQLite ignores
the length, so the SQLite default never showed it). Rows already indexed keep their values.

SQLite does not enforce ``VARCHAR(n)``: there the columns are left as they are (a table rebuild
would gain nothing); the model in ``hil/results/schema.py`` is what new SQLite files get.

Revision ID: 0003
Revises: 0002
"""
import sqlalchemy as sa
from alembic import op

revision = "0003"
down_revision = "0002"

#: table → (column, its length before this migration), every one now Text.
WIDENED = {
    "runs": (("status", 32), ("statement", 32), ("created_utc", 32), ("finished_utc", 32),
             ("software_version", 64), ("git_sha", 64), ("station", 200), ("operator", 200),
             ("dut_serial", 200), ("drive_serial", 200), ("drive_firmware", 200),
             ("motor_serial", 200)),
    "points": (("source", 64), ("kind", 32), ("outcome", 16), ("decision", 32)),
    "requirement_verdicts": (("requirement_id", 100), ("quantity", 64), ("unit", 16),
                             ("rule", 32), ("decision", 32)),
    "diagnosis_estimates": (("name", 100), ("unit", 16)),
}


def _alter(to_text: bool) -> None:
    if op.get_bind().dialect.name == "sqlite":
        return
    for table, columns in WIDENED.items():
        for column, length in columns:
            old, new = sa.String(length), sa.Text()
            op.alter_column(table, column, existing_type=new if not to_text else old,
                            type_=new if to_text else old)


def upgrade() -> None:
    _alter(to_text=True)


def downgrade() -> None:
    _alter(to_text=False)
