"""`wheelscan run-demo`: migrate, load a simulated demo pass, print a viewer's URL and serve."""

from __future__ import annotations

import argparse
import sys

from backend.cli.serve import add_server_arguments, serve
from backend.cli.token import issue_token
from backend.config import settings_from_args


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add `run-demo`."""
    demo = subparsers.add_parser(
        "run-demo", help="migrate, load a simulated demo pass, print a viewer URL and serve"
    )
    add_server_arguments(demo)
    demo.add_argument("--vehicles", type=int, default=3, help="vehicles in the demo pass")
    demo.set_defaults(func=run_demo)


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
