"""`wheelscan migrate`: bring a deployment's database to the newest schema (the scale-out
deployment runs it before its workers and service start; see docker-compose.yml)."""

from __future__ import annotations

import argparse
import sys

from backend.config import add_settings_arguments, settings_from_args
from db.engine import make_engine, upgrade_database


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add `migrate`."""
    migrate = subparsers.add_parser(
        "migrate", help="bring the database (WHEELSCAN_DATABASE_URL) to the newest schema"
    )
    add_settings_arguments(migrate)
    migrate.set_defaults(func=run_migrate)


def run_migrate(args: argparse.Namespace) -> int:
    settings = settings_from_args(args)
    engine = make_engine(settings.resolved_database_url)
    try:
        upgrade_database(engine)
    finally:
        engine.dispose()
    sys.stderr.write("wheelscan migrate: database at the newest schema\n")
    return 0
