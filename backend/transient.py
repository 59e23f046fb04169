"""Faults that pass: a database that is unreachable or restarting, a frame store that does
not answer, a full disk. A request meeting one is answered 503 or 507 (`backend.api.outages`);
a measurement meeting one is tried again later (`backend.jobs.runner`) instead of failing.

No web framework here: the measurement workers import it too.
"""

from __future__ import annotations

import errno

from sqlalchemy.exc import InterfaceError, OperationalError
from sqlalchemy.exc import TimeoutError as PoolTimeoutError

DATABASE_ERRORS: tuple[type[Exception], ...] = (OperationalError, InterfaceError, PoolTimeoutError)
"""Errors of a database that is unreachable, restarting or busy."""
DISK_FULL_ERRNOS = frozenset({errno.ENOSPC, errno.EDQUOT})


def is_disk_full(exc: BaseException) -> bool:
    """Whether `exc` says the disk (or the quota) is full: an OSError, or SQLite's
    "database or disk is full" (SQLITE_FULL)."""
    if isinstance(exc, OSError):
        return exc.errno in DISK_FULL_ERRNOS
    if isinstance(exc, OperationalError):
        return "database or disk is full" in str(exc.orig)
    return False


def is_transient(exc: BaseException) -> bool:
    """Whether `exc` is a fault that passes (see the module docstring)."""
    return isinstance(exc, (*DATABASE_ERRORS, ConnectionError)) or is_disk_full(exc)
