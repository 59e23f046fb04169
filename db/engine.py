"""Engine and session factory, and the one way to bring a database to the newest schema."""

from __future__ import annotations

from pathlib import Path

from alembic import command
from alembic.config import Config
from sqlalchemy import Connection, Engine, create_engine, event
from sqlalchemy.engine import make_url
from sqlalchemy.exc import DBAPIError
from sqlalchemy.orm import Session, sessionmaker

MIGRATIONS_DIR = Path(__file__).resolve().parent / "migrations"

SQLITE_BUSY_TIMEOUT_S = 30.0
"""How long a SQLite writer waits for another process's write lock before failing."""
POOL_SIZE, POOL_OVERFLOW = 10, 30
"""Connections an engine keeps, and may open beyond them: 40 in all, one for each of the
server's request threads (anyio's default), so under load a request never waits for a
connection (30 s, then 503) while others hold theirs through slow work (uploads being
validated, PDF reports). An in-memory SQLite database keeps its single connection."""


def make_engine(database_url: str) -> Engine:
    """Create an engine for `database_url` (sqlite:///… or postgresql+psycopg://…).

    SQLite gets foreign keys on, write-ahead logging (readers never block the one writer)
    and a busy timeout, so the server and its worker processes can share the file; the
    file's folder is created when missing.
    """
    url = make_url(database_url)
    if url.get_backend_name() != "sqlite":
        return create_engine(
            url, pool_pre_ping=True, pool_size=POOL_SIZE, max_overflow=POOL_OVERFLOW
        )
    in_memory = not url.database or url.database == ":memory:"
    if not in_memory:
        Path(str(url.database)).parent.mkdir(parents=True, exist_ok=True)
    engine = create_engine(
        url,
        connect_args={"check_same_thread": False, "timeout": SQLITE_BUSY_TIMEOUT_S},
        **({} if in_memory else {"pool_size": POOL_SIZE, "max_overflow": POOL_OVERFLOW}),
    )
    event.listen(engine, "connect", _configure_sqlite_connection)
    event.listen(engine, "savepoint", _begin_before_savepoint)
    return engine


def _begin_before_savepoint(connection: Connection, _name: str) -> None:
    """Open the SQLite transaction a savepoint belongs to.

    sqlite3 begins a transaction only before its first INSERT/UPDATE/DELETE; a SAVEPOINT
    issued before that starts one of its own, and releasing it commits, so a row created
    in a savepoint (a new site or wheel) outlived the request that was then refused.
    """
    dbapi_connection = connection.connection.dbapi_connection
    if dbapi_connection is not None and not dbapi_connection.in_transaction:  # type: ignore[attr-defined]
        dbapi_connection.execute("BEGIN")  # type: ignore[attr-defined]


def _configure_sqlite_connection(dbapi_connection: object, _record: object) -> None:
    cursor = dbapi_connection.cursor()  # type: ignore[attr-defined]
    cursor.execute("PRAGMA foreign_keys=ON")
    cursor.execute("PRAGMA journal_mode=WAL")
    cursor.execute(f"PRAGMA busy_timeout={int(SQLITE_BUSY_TIMEOUT_S * 1000)}")
    cursor.close()


class _Session(Session):
    """A Session whose close() does not fail when the database has dropped the connection
    (PostgreSQL restarted): the server rolled the transaction back as the connection ended,
    so nothing is left to undo, and a request that was answered stays answered."""

    def close(self) -> None:
        try:
            super().close()
        except DBAPIError as exc:
            if not exc.connection_invalidated:
                raise


def make_session_factory(engine: Engine) -> sessionmaker[Session]:
    """Sessions bound to `engine`; loaded objects stay readable after commit."""
    return sessionmaker(engine, class_=_Session, expire_on_commit=False)


def alembic_config(engine: Engine) -> Config:
    """An Alembic configuration that runs the project's migrations on `engine`."""
    config = Config()
    config.set_main_option("script_location", str(MIGRATIONS_DIR))
    config.attributes["engine"] = engine
    return config


def upgrade_database(engine: Engine, revision: str = "head") -> None:
    """Migrate the database behind `engine` up to `revision` (default: the newest)."""
    command.upgrade(alembic_config(engine), revision)


def downgrade_database(engine: Engine, revision: str) -> None:
    """Migrate the database behind `engine` down to `revision` ("base" empties it)."""
    command.downgrade(alembic_config(engine), revision)
