"""`wheelscan serve`, `wheelscan token create`, `wheelscan run-demo`: the service from the CLI."""

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
    """Add the service verbs."""
    serve = subparsers.add_parser(
        "serve", help="run the HTTP service (migrates the database first)"
    )
    _add_server_arguments(serve)
    serve.set_defaults(func=run_serve)

    token = subparsers.add_parser("token", help="manage API tokens")
    token_verbs = token.add_subparsers(dest="token_verb", required=True, metavar="ACTION")
    create = token_verbs.add_parser("create", help="create a token and print it (shown once)")
    create.add_argument("--role", required=True, choices=ROLES)
    create.add_argument("--name", default="cli", help="what the token is for")
    create.add_argument("--days", type=float, help="expire after this many days (default: never)")
    add_settings_arguments(create)
    create.set_defaults(func=run_token_create)

    demo = subparsers.add_parser(
        "run-demo", help="migrate, load a simulated demo pass, print a viewer URL and serve"
    )
    _add_server_arguments(demo)
    demo.add_argument("--vehicles", type=int, default=3, help="vehicles in the demo pass")
    demo.set_defaults(func=run_demo)


def _add_server_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--host", help="interface to listen on (WHEELSCAN_HOST, 127.0.0.1)")
    parser.add_argument("--port", type=int, help="TCP port (WHEELSCAN_PORT, 8000)")
    parser.add_argument("--workers", type=int, help="measurement processes (WHEELSCAN_WORKERS)")
    add_settings_arguments(parser)


def serve(settings: Settings) -> None:
    """Run the service in the foreground until interrupted."""
    import uvicorn

    from backend.api.app import create_app

    uvicorn.run(create_app(settings), host=settings.host, port=settings.port, log_level="info")


def run_serve(args: argparse.Namespace) -> int:
    settings = settings_from_args(args)
    sys.stderr.write(
        f"wheelscan: serving on http://{settings.host}:{settings.port}/ (docs at /docs)\n"
    )
    serve(settings)
    return 0


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


def run_demo(args: argparse.Namespace) -> int:
    from backend.ops.demo import load_demo

    settings = settings_from_args(args)
    if args.vehicles < 1:
        raise ValueError(f"--vehicles must be ≥ 1, got {args.vehicles}")
    pass_id = load_demo(settings, vehicles=args.vehicles)
    token = issue_token(settings, "viewer", "demo viewer")
    url = f"http://{settings.host}:{settings.port}/#token={token}"
    sys.stdout.write(
        f"wheelscan demo: pass {pass_id} loaded; its wheels are measured as the server runs.\n"
        f"open {url}\n(API docs: http://{settings.host}:{settings.port}/docs)\n"
    )
    sys.stdout.flush()
    serve(settings)
    return 0
