"""Every table of the results database as CSV (standard library) or Parquet (pyarrow, optional:
the project does not depend on it; without it the export says so and writes nothing)."""

from __future__ import annotations

import csv
from pathlib import Path

from hil.errors import InputError
from hil.results.schema import TABLES


def export_tables(engine, folder: str | Path, fmt: str) -> dict[str, int]:
    """Write ``<table>.csv`` or ``<table>.parquet`` per table into ``folder``; path → rows."""
    from sqlalchemy import select

    if fmt == "parquet":
        try:
            import pyarrow
            import pyarrow.parquet as parquet
        except ImportError:
            raise InputError("--format parquet needs pyarrow, which is not installed "
                             "(pip install pyarrow), or use --format csv") from None
    elif fmt != "csv":
        raise InputError(f"--format {fmt!r}: csv or parquet")
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    written = {}
    with engine.connect() as connection:
        for table in TABLES:
            names = [c.name for c in table.columns]
            rows = [dict(r._mapping) for r in connection.execute(
                select(table).order_by(*table.primary_key.columns))]
            path = folder / f"{table.name}.{fmt}"
            if fmt == "csv":
                with open(path, "w", newline="", encoding="utf-8") as handle:
                    writer = csv.DictWriter(handle, fieldnames=names)
                    writer.writeheader()
                    writer.writerows(rows)
            else:
                columns = {name: [row[name] for row in rows] for name in names}
                parquet.write_table(pyarrow.table(columns), path)
            written[str(path)] = len(rows)
    return written
