"""Throw-away databases for tests: a SQLite file and a fresh PostgreSQL database.

Both are real (docs/style.md §7): the PostgreSQL one is created on the local server
(127.0.0.1:5432, trust auth) for one test session and dropped afterwards.
"""

from __future__ import annotations

import secrets
import subprocess
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import psycopg
import pytest

POSTGRES_ADMIN_DSN = "host=127.0.0.1 port=5432 user=postgres dbname=test"
POSTGRES_URL_TEMPLATE = "postgresql+psycopg://postgres@127.0.0.1:5432/{name}"
BACKENDS = ("sqlite", "postgresql")


def _connect_admin() -> psycopg.Connection:
    try:
        return psycopg.connect(POSTGRES_ADMIN_DSN, autocommit=True, connect_timeout=5)
    except psycopg.OperationalError:
        subprocess.run(
            "pg_ctlcluster --skip-systemctl-redirect $(ls /etc/postgresql) main start",
            shell=True,
            check=False,
            capture_output=True,
        )
        try:
            return psycopg.connect(POSTGRES_ADMIN_DSN, autocommit=True, connect_timeout=5)
        except psycopg.OperationalError as exc:
            pytest.skip(f"PostgreSQL at 127.0.0.1:5432 is down and would not start: {exc}")


@contextmanager
def throwaway_database(backend: str, tmp_dir: Path) -> Iterator[str]:
    """Yield the URL of an empty database of `backend`, removed on exit."""
    if backend == "sqlite":
        yield f"sqlite:///{tmp_dir / 'wheelscan-test.db'}"
        return
    name = f"wheelscan_test_{secrets.token_hex(6)}"
    with _connect_admin() as admin:
        admin.execute(f'CREATE DATABASE "{name}"')
    try:
        yield POSTGRES_URL_TEMPLATE.format(name=name)
    finally:
        with _connect_admin() as admin:
            admin.execute(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)')
