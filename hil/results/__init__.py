"""The results database (design.md §10, issue 24): every sealed run record indexed for history,
run-to-run comparison, trends and measured-vs-predicted yield. A sink: it reads sealed records
only and never fails or slows a run (``index_after_run``); ``hil db sync`` indexes what is missing.

Modules: ``schema`` (tables), ``migrations`` (Alembic), ``db`` (URL, engine, migration),
``extract`` (record → rows), ``ingest`` (idempotent indexing), ``queries`` (history, compare,
trend), ``capability`` (Cp/Cpk and yield intervals), ``fleet_yield`` (tolerances from diagnosed
units).
"""

from hil.results.ingest import index_after_run, verify_row

__all__ = ["index_after_run", "verify_row"]
