"""`wheelscan retention [--dry-run] [--days N]`: remove the raw frames of old passes now.

The server applies the same retention by itself every `WHEELSCAN_RETENTION_SWEEP_INTERVAL_S`
when `WHEELSCAN_FRAME_RETENTION_DAYS` is set; this verb applies it once (or shows with
`--dry-run` what it would remove) and prints one line per pass.
"""

from __future__ import annotations

import argparse
import sys

from backend.config import MIB, add_settings_arguments, settings_from_args
from backend.services.retention import PassRemoval, remove_expired_frames
from backend.storage.store import BlobStore
from db.engine import make_engine, make_session_factory, upgrade_database


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the retention verb."""
    retention = subparsers.add_parser(
        "retention",
        help="remove raw frames of passes older than the retention (results are kept)",
    )
    retention.add_argument(
        "--days",
        type=float,
        help="keep frames of passes started in the last DAYS days "
        "(default WHEELSCAN_FRAME_RETENTION_DAYS)",
    )
    retention.add_argument(
        "--dry-run", action="store_true", help="show what would be removed; remove nothing"
    )
    add_settings_arguments(retention)
    retention.set_defaults(func=run_retention)


def _describe(removal: PassRemoval, dry_run: bool) -> str:
    verb = "would remove" if dry_run else "removed"
    return (
        f"pass {removal.pass_id} (started {removal.started_at:%Y-%m-%d %H:%M} UTC): {verb} "
        f"{removal.blobs_removed} blob(s), {removal.bytes_removed / MIB:.1f} MiB; "
        f"{removal.blobs_kept_shared} kept (shared with newer passes)\n"
    )


def run_retention(args: argparse.Namespace) -> int:
    settings = settings_from_args(args)
    days = args.days if args.days is not None else settings.frame_retention_days
    if days is None:
        raise ValueError(
            "no retention configured: set WHEELSCAN_FRAME_RETENTION_DAYS or pass --days"
        )
    if days <= 0:
        raise ValueError(f"--days must be > 0, got {days}")
    engine = make_engine(settings.resolved_database_url)
    try:
        upgrade_database(engine)
        with make_session_factory(engine)() as session:
            removals = remove_expired_frames(
                session,
                BlobStore(settings.frames_dir),
                days,
                dry_run=args.dry_run,
                actor="cli",
            )
    finally:
        engine.dispose()
    for removal in removals:
        sys.stdout.write(_describe(removal, args.dry_run))
    total = sum(r.bytes_removed for r in removals)
    verb = "would free" if args.dry_run else "freed"
    sys.stdout.write(f"{len(removals)} pass(es) older than {days:g} days; {verb} {total} bytes\n")
    return 0
