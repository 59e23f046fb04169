"""`wheelscan serve`: the HTTP service from the CLI (migrates the database first)."""

from __future__ import annotations

import argparse
import sys

from backend.config import Settings, add_settings_arguments, settings_from_args


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add `serve`."""
    serve = subparsers.add_parser(
        "serve", help="run the HTTP service (migrates the database first)"
    )
    add_server_arguments(serve)
    serve.set_defaults(func=run_serve)


def add_server_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the options of a verb that serves (`serve`, `run-demo`): host, port, workers."""
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
