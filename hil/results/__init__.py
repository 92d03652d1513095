"""The results database (design.md §10, issue 24): every sealed run record indexed for history,
run-to-run comparison, trends and measured-vs-predicted yield. A sink: it reads sealed records
only and never fails or slows a run (``index_after_run``); ``hil db sync`` indexes what is missing.

Modules: ``schema`` (tables), ``migrations`` (Alembic), ``db`` (URL, engine, migration),
``extract`` (record → rows), ``ingest`` (idempotent indexing), ``queries`` (history, compare,
trend), ``capability`` (Cp/Cpk and yield intervals), ``fleet_yield`` (tolerances from diagnosed
units).
"""

__all__ = ["index_after_run", "verify_row"]


def __getattr__(name: str):
    """``index_after_run`` and ``verify_row`` load :mod:`hil.results.ingest` (SQLAlchemy) on
    first use, so that a command's ``--help`` naming a database option imports no database."""
    if name in __all__:
        from hil.results import ingest

        return getattr(ingest, name)
    raise AttributeError(f"module 'hil.results' has no attribute {name!r}")
