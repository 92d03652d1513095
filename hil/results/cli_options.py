"""Options every results-database command shares: where the database is."""

from __future__ import annotations

from pathlib import Path


def add_database_options(parser) -> None:
    parser.add_argument("--results-db", metavar="URL",
                        help="database URL (postgresql://user@host/db or an SQLite path); "
                             "default: $RIPPLE_HIL_RESULTS_DB, else [results] url of --bench, "
                             "else RECORDS/results.sqlite")
    parser.add_argument("--bench", metavar="FILE", type=Path,
                        help="bench file whose [results] url names the database")
    parser.add_argument("--records", metavar="DIR", type=Path, default=Path("records"),
                        help="records folder (default: records)")


def engine_from_args(args):
    """The engine the options name (schema migrated to head)."""
    from hil.results.db import engine_for, resolve_url

    return engine_for(resolve_url(args.results_db, args.bench, args.records))


def database_error(exc: Exception, args) -> Exception:
    """A database that cannot be reached as one :class:`HilError` line."""
    from hil.errors import HilError
    from hil.results.db import display_url, resolve_url

    first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
    return HilError(f"results database {display_url(resolve_url(args.results_db, args.bench, args.records))}: "
                    f"{first[:300]}")
