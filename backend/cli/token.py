"""`wheelscan token create`: an API token for a role, printed once."""

from __future__ import annotations

import argparse
import sys
from datetime import timedelta

from backend.config import Settings, add_settings_arguments, settings_from_args
from backend.services.auth import grant_token
from db.engine import make_engine, make_session_factory, upgrade_database
from db.models import ROLES
from db.types import utc_now


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add `token` (and its action `create`)."""
    token = subparsers.add_parser("token", help="manage API tokens")
    token_verbs = token.add_subparsers(dest="token_verb", required=True, metavar="ACTION")
    create = token_verbs.add_parser("create", help="create a token and print it (shown once)")
    create.add_argument("--role", required=True, choices=ROLES)
    create.add_argument("--name", default="cli", help="what the token is for")
    create.add_argument("--days", type=float, help="expire after this many days (default: never)")
    add_settings_arguments(create)
    create.set_defaults(func=run_token_create)


def issue_token(settings: Settings, role: str, name: str, days: float | None = None) -> str:
    """Create a token in the settings' database (migrated first); returns the plaintext."""
    if days is not None and days <= 0:
        raise ValueError(f"--days must be > 0, got {days}")
    engine = make_engine(settings.resolved_database_url)
    try:
        upgrade_database(engine)
        with make_session_factory(engine)() as session:
            expires_at = utc_now() + timedelta(days=days) if days is not None else None
            _, plaintext = grant_token(session, None, role=role, name=name, expires_at=expires_at)
    finally:
        engine.dispose()
    return plaintext


def run_token_create(args: argparse.Namespace) -> int:
    sys.stdout.write(issue_token(settings_from_args(args), args.role, args.name, args.days) + "\n")
    return 0
