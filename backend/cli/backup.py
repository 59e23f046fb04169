"""`wheelscan backup OUT` and `wheelscan restore IN`: the database and the frame store as
one consistent archive (backend/ops/snapshot.py describes the format)."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

from sqlalchemy.exc import SQLAlchemyError

from backend.config import MIB, add_settings_arguments, settings_from_args
from backend.ops.snapshot import Manifest

T = TypeVar("T")


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the backup verbs."""
    backup = subparsers.add_parser(
        "backup",
        help="write the database and the frame store to one archive (safe while serving)",
    )
    backup.add_argument(
        "out", type=Path, metavar="OUT", help="new archive: .tar, or .tar.gz/.tgz compressed"
    )
    add_settings_arguments(backup)
    backup.set_defaults(func=run_backup)

    restore = subparsers.add_parser(
        "restore", help="restore a backup into an empty data directory and empty database"
    )
    restore.add_argument("archive", type=Path, metavar="IN", help="archive from `backup`")
    add_settings_arguments(restore)
    restore.set_defaults(func=run_restore)


def run_backup(args: argparse.Namespace) -> int:
    from backend.ops.backup import create_backup

    summary = _with_database_errors(lambda: create_backup(settings_from_args(args), args.out))
    sys.stdout.write(
        f"wheelscan backup: wrote {summary.path} ({summary.archive_bytes / MIB:.1f} MiB: "
        f"{_contents(summary.manifest)}) in {summary.seconds:.1f} s\n"
    )
    return 0


def run_restore(args: argparse.Namespace) -> int:
    from backend.ops.restore import restore_backup

    summary = _with_database_errors(lambda: restore_backup(settings_from_args(args), args.archive))
    sys.stdout.write(
        f"wheelscan restore: restored {args.archive} ({_contents(summary.manifest)}) "
        f"in {summary.seconds:.1f} s\n"
    )
    return 0


def _contents(manifest: Manifest) -> str:
    rows = sum(table.rows for table in manifest.tables)
    return (
        f"{rows} rows in {len(manifest.tables)} tables, {len(manifest.blobs)} blobs, "
        f"{manifest.dialect} schema {manifest.revision}"
    )


def _with_database_errors(work: Callable[[], T]) -> T:
    """Run `work`; a database error becomes a one-line ValueError (exit status 2)."""
    try:
        return work()
    except SQLAlchemyError as exc:
        cause = str(getattr(exc, "orig", None) or exc).strip().splitlines()
        raise ValueError(f"database: {cause[0] if cause else type(exc).__name__}") from None
