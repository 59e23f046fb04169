"""Wheel leases: which live worker may measure a pass wheel right now.

A Celery message is delivered again when its worker dies (SIGKILL, power loss, a lost
connection) or outlives the broker's visibility timeout. The task's own claim
(queued → running) cannot tell those apart: after a crash the wheel stays "running" with
no one measuring it. A lease can. It is a lock that the *database server or the kernel*
releases the moment its holder's process dies:

- PostgreSQL: a session-level advisory lock, held on a connection of its own for as long
  as the wheel is measured; the server drops it when that connection closes.
- SQLite (one machine only): an exclusive `flock` on `<data>/leases/<id>.lock`, dropped
  by the kernel when the process exits.

Whoever holds the lease may re-queue a wheel left "running" (its previous owner is dead)
and measure it; whoever cannot get it knows a live worker is on it. Two live workers never
hold the same lease, and the results' unique key (pass wheel × method) stores a wheel once
even if a lease were lost mid-measurement (a PostgreSQL restart).

Where leases sit among the runners and retries: docs/service.md, "Jobs".
"""

from __future__ import annotations

import fcntl
import logging
import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any, cast

from sqlalchemy import Connection, CursorResult, Engine, text, update
from sqlalchemy.orm import Session

from db.models import PassWheel

logger = logging.getLogger(__name__)

LEASE_LOCK_CLASS = 0x5753
"""First key of `pg_try_advisory_lock(int, int)`: the lock space of pass-wheel leases."""


@contextmanager
def hold_wheel_lease(engine: Engine, leases_dir: Path, pass_wheel_id: int) -> Iterator[bool]:
    """Try to take the lease of one pass wheel; yields whether it was taken.

    Parameters
    ----------
    engine : Engine
        The database of the wheel (PostgreSQL: advisory lock; SQLite: a lock file).
    leases_dir : Path
        Folder of the lock files (SQLite only; created when missing).
    pass_wheel_id : int
        Row id in `pass_wheel`.

    Yields
    ------
    bool
        True while this process holds the lease (released on exit), False when another
        live process holds it.
    """
    if pass_wheel_id < 1:
        raise ValueError(f"pass_wheel_id must be ≥ 1, got {pass_wheel_id}")
    if engine.dialect.name == "postgresql":
        with _advisory_lease(engine, pass_wheel_id) as held:
            yield held
    else:
        with _file_lease(leases_dir, pass_wheel_id) as held:
            yield held


@contextmanager
def _advisory_lease(engine: Engine, pass_wheel_id: int) -> Iterator[bool]:
    key = {"lock_class": LEASE_LOCK_CLASS, "wheel_id": pass_wheel_id}
    with engine.connect() as connection:
        held = bool(
            connection.scalar(text("SELECT pg_try_advisory_lock(:lock_class, :wheel_id)"), key)
        )
        connection.commit()
        try:
            yield held
        finally:
            if held:
                _release_advisory_lock(connection, key)


def _release_advisory_lock(connection: Connection, key: dict[str, int]) -> None:
    try:
        connection.execute(text("SELECT pg_advisory_unlock(:lock_class, :wheel_id)"), key)
        connection.commit()
    except Exception:
        # A connection that may still hold the lock must never go back to the pool:
        # closing it for good is what releases the lock on the server.
        logger.warning(
            "lease of pass wheel %d: unlock failed, dropping the connection", key["wheel_id"]
        )
        connection.invalidate()


@contextmanager
def _file_lease(leases_dir: Path, pass_wheel_id: int) -> Iterator[bool]:
    leases_dir.mkdir(parents=True, exist_ok=True)
    descriptor = os.open(leases_dir / f"{pass_wheel_id}.lock", os.O_RDWR | os.O_CREAT, 0o644)
    try:
        try:
            fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            yield False
            return
        yield True
    finally:
        os.close(descriptor)


def requeue_orphaned_wheel(session: Session, pass_wheel_id: int) -> bool:
    """running → queued for a wheel whose owner died; call only while holding its lease.

    Returns whether the wheel was orphaned (and is now queued again).
    """
    result = cast(
        CursorResult[Any],
        session.execute(
            update(PassWheel)
            .where(PassWheel.id == pass_wheel_id, PassWheel.state == "running")
            .values(state="queued")
        ),
    )
    session.commit()
    return result.rowcount == 1
