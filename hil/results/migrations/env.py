"""Alembic environment of the results database: migrations run on the connection the caller
passes in ``config.attributes["connection"]`` (hil.results.db.upgrade), never from an ini file."""

from alembic import context

from hil.results.schema import metadata

connection = context.config.attributes["connection"]
context.configure(connection=connection, target_metadata=metadata,
                  render_as_batch=connection.dialect.name == "sqlite")
with context.begin_transaction():
    context.run_migrations()
