"""Where the results database is and how to open it (engine, schema at the newest migration).

The URL, first given wins: ``--results-db URL`` on the command line, the environment variable
``RIPPLE_HIL_RESULTS_DB``, ``[results] url`` in the bench file, else the SQLite file
``<records folder>/results.sqlite`` (default ``records/results.sqlite``); ``off`` (or ``none``)
turns indexing after a run off. A lab points every
station at one PostgreSQL (``postgresql://user@host/db``; the driver is psycopg 3).

Opening a database brings its schema to the newest Alembic migration (``migrations/``) under a
lock (PostgreSQL: an advisory lock; SQLite: a lock file beside the database), so several stations
starting at once migrate it once. A database already at head costs one ``SELECT``.
"""

from __future__ import annotations

import contextlib
import os
import tomllib
from pathlib import Path

from hil.errors import InputError

ENV_VAR = "RIPPLE_HIL_RESULTS_DB"
#: URLs that switch the results database off.
DISABLED = ("off", "none")
DEFAULT_FILE = "results.sqlite"
#: Seconds a PostgreSQL connection attempt may take before the database counts as down.
CONNECT_TIMEOUT_S = 3
#: Seconds an SQLite writer waits for another station's transaction.
SQLITE_BUSY_TIMEOUT_S = 30
MIGRATIONS = Path(__file__).with_name("migrations")
#: PostgreSQL advisory-lock key under which the schema is migrated (any fixed 64-bit number).
_MIGRATION_LOCK = 0x7269_7070_6c65


def resolve_url(cli_url: str | None = None, bench_file: str | Path | None = None,
                records_dir: str | Path = "records") -> str:
    """The database URL by the rule in the module docstring."""
    if cli_url:
        return cli_url if cli_url.lower() in ("off", "none") else normalise_url(cli_url)
    if os.environ.get(ENV_VAR):
        env = os.environ[ENV_VAR]
        return env if env.lower() in ("off", "none") else normalise_url(env)
    if bench_file is not None:
        url = bench_results_url(bench_file)
        if url:
            return url if is_disabled(url) else normalise_url(url)
    return f"sqlite:///{Path(records_dir).resolve() / DEFAULT_FILE}"


def is_disabled(url: str) -> bool:
    """``url`` (as :func:`resolve_url` gives it) switches the results database off."""
    return url.strip().lower() in DISABLED


def bench_results_url(bench_file: str | Path) -> str | None:
    """``[results] url`` of a bench file, or None (read with tomllib, nothing else checked)."""
    try:
        table = tomllib.loads(Path(bench_file).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise InputError(f"bench file {bench_file}: {exc}") from None
    results = table.get("results") or {}
    url = results.get("url") if isinstance(results, dict) else None
    if url is not None and not isinstance(url, str):
        raise InputError(f"bench file {bench_file}: results.url must be a string")
    return url


def normalise_url(url: str) -> str:
    """``postgresql://`` means psycopg 3 (SQLAlchemy's default would be psycopg2); a bare path is
    an SQLite file."""
    if url.startswith(("postgresql://", "postgres://")):
        return "postgresql+psycopg://" + url.split("://", 1)[1]
    if "://" not in url:
        return f"sqlite:///{Path(url).resolve()}"
    return url


def display_url(url: str) -> str:
    """The URL without its password (for messages)."""
    from sqlalchemy.engine import make_url

    return make_url(url).render_as_string(hide_password=True)


_ENGINES: dict[str, object] = {}


def engine_for(url: str, *, migrate: bool = True):
    """A cached SQLAlchemy engine for ``url``, its schema migrated to head (``migrate``)."""
    from sqlalchemy import create_engine, event

    url = normalise_url(url)
    engine = _ENGINES.get(url)
    if engine is not None:
        return engine
    if url.startswith("sqlite"):
        path = url.split("///", 1)[1] if "///" in url else ""
        if path and path != ":memory:":
            Path(path).parent.mkdir(parents=True, exist_ok=True)
        engine = create_engine(url, connect_args={"timeout": SQLITE_BUSY_TIMEOUT_S})

        @event.listens_for(engine, "connect")
        def _sqlite_pragmas(dbapi_connection, _record):     # WAL: readers never block a writer
            cursor = dbapi_connection.cursor()
            cursor.execute("PRAGMA journal_mode=WAL")
            cursor.execute("PRAGMA foreign_keys=ON")
            cursor.execute("PRAGMA synchronous=NORMAL")
            cursor.close()
    else:
        engine = create_engine(url, connect_args={"connect_timeout": CONNECT_TIMEOUT_S},
                               pool_pre_ping=True)
    if migrate:
        upgrade(engine)
    _ENGINES[url] = engine
    return engine


def dispose_all() -> None:
    """Close every cached engine (tests; a process that forks)."""
    for engine in _ENGINES.values():
        engine.dispose()
    _ENGINES.clear()


def head_revision() -> str:
    """The newest migration's revision id: the one no migration revises.

    Read from the migration files' ``revision`` / ``down_revision`` assignments with ``ast``, not
    through alembic's ``ScriptDirectory`` (importing alembic costs ~0.2 s of every ``hil run``
    that indexes its record into a database already at head); a test holds it equal to
    alembic's own answer. More than one head (a branch) is refused, as alembic's ``upgrade
    head`` would.
    """
    import ast

    revisions: dict[str, object] = {}
    for path in sorted((MIGRATIONS / "versions").glob("*.py")):
        if path.name.startswith((".", "_")):         # __init__.py, an editor's lock file
            continue
        found = {}
        for node in ast.parse(path.read_text(encoding="utf-8")).body:
            if isinstance(node, ast.AnnAssign):       # revision: str = "…" (alembic's template)
                target, value = node.target, node.value
            elif isinstance(node, ast.Assign) and len(node.targets) == 1:
                target, value = node.targets[0], node.value
            else:
                continue
            if isinstance(target, ast.Name) and target.id in ("revision", "down_revision"):
                found[target.id] = ast.literal_eval(value)
        if not isinstance(found.get("revision"), str):
            raise RuntimeError(f"results migration {path.name} states no literal revision id")
        revisions[found["revision"]] = found.get("down_revision")
    revised = set()
    for down in revisions.values():
        revised.update(down if isinstance(down, (tuple, list)) else (down,))
    heads = sorted(set(revisions) - revised)
    if len(heads) != 1:
        raise RuntimeError(f"the results migrations have {len(heads)} heads {heads}, not one")
    return heads[0]


def current_revision(connection) -> str | None:
    """The revision the database is at (None: no schema yet)."""
    from sqlalchemy import inspect, text

    if not inspect(connection).has_table("alembic_version"):
        return None
    return connection.execute(text("SELECT version_num FROM alembic_version")).scalar()


_HEAD_CACHE: list[str] = []


def upgrade(engine, revision: str = "head") -> None:
    """Migrate the schema to ``revision`` (default the newest), once across stations."""
    if revision == "head":
        if not _HEAD_CACHE:
            _HEAD_CACHE.append(head_revision())
        target = _HEAD_CACHE[0]
    else:
        target = revision
    with engine.connect() as connection:
        if current_revision(connection) == target:
            return
    with _migration_lock(engine):
        with engine.begin() as connection:
            if current_revision(connection) == target:
                return
            from alembic import command
            from alembic.config import Config

            config = Config()
            config.set_main_option("script_location", str(MIGRATIONS))
            config.attributes["connection"] = connection
            command.upgrade(config, revision)


@contextlib.contextmanager
def _migration_lock(engine):
    if engine.dialect.name == "postgresql":
        from sqlalchemy import text

        with engine.connect() as connection:
            connection.execute(text("SELECT pg_advisory_lock(:k)"), {"k": _MIGRATION_LOCK})
            connection.commit()
            try:
                yield
            finally:
                connection.execute(text("SELECT pg_advisory_unlock(:k)"), {"k": _MIGRATION_LOCK})
                connection.commit()
    elif engine.dialect.name == "sqlite" and engine.url.database not in (None, "", ":memory:"):
        import fcntl

        with open(f"{engine.url.database}.lock", "a") as handle:
            fcntl.flock(handle, fcntl.LOCK_EX)
            try:
                yield
            finally:
                fcntl.flock(handle, fcntl.LOCK_UN)
    else:
        yield
