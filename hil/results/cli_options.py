"""Options every results-database command shares: where the database is."""

from __future__ import annotations

import os
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


def engine_from_args(args, *, create: bool = False):
    """The engine the options name (schema migrated to head). A command that only reads
    (``create`` False: history, compare, trend, yield) refuses an SQLite file that does not
    exist, saying where it looked and why there, instead of creating an empty one and finding
    nothing in it (issue 32 item 6)."""
    from hil.errors import InputError
    from hil.results.db import ENV_VAR, engine_for, resolve_url

    url = resolve_url(args.results_db, args.bench, args.records)
    if url.lower() in ("off", "none"):
        raise InputError(f"the results database is turned off ({url!r}); give --results-db URL")
    if not create and url.startswith("sqlite:///") and ":memory:" not in url:
        path = Path(url.split("///", 1)[1])
        if not path.exists():
            why = ("--results-db" if args.results_db else f"${ENV_VAR}"
                   if os.environ.get(ENV_VAR) else
                   f"the default: the records folder {args.records}/ of the current folder "
                   f"{Path.cwd()}")
            raise InputError(f"no results database at {path} (looked there by {why}); run "
                             f"where the records are, or give --records DIR or --results-db URL")
    return engine_for(url)


def database_error(exc: Exception, args) -> Exception:
    """A database that cannot be reached as one :class:`HilError` line."""
    from hil.errors import HilError
    from hil.results.db import display_url, resolve_url

    first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
    return HilError(f"results database {display_url(resolve_url(args.results_db, args.bench, args.records))}: "
                    f"{first[:300]}")
