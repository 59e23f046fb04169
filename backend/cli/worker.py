"""`wheelscan worker`: a Celery worker measuring wheels, for a scale-out deployment (see
docker-compose.yml; its database is brought to the newest schema by `wheelscan migrate`)."""

from __future__ import annotations

import argparse
import socket
import sys
from typing import TYPE_CHECKING

from backend.config import add_settings_arguments, settings_from_args

if TYPE_CHECKING:
    from celery import Celery

WORKER_PING_TIMEOUT_S = 5.0


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add `worker`."""
    worker = subparsers.add_parser(
        "worker",
        help="measure queued wheels from the Celery broker (needs WHEELSCAN_BROKER_URL)",
    )
    worker.add_argument(
        "--concurrency",
        type=int,
        default=1,
        help="measuring processes in this worker (default 1; one per core is the most useful)",
    )
    worker.add_argument(
        "--pool",
        choices=("prefork", "solo"),
        default="prefork",
        help="prefork: child processes (a crashed child loses no wheel); solo: in this process",
    )
    worker.add_argument("--hostname", help="Celery node name (default: worker@<host>-<pid>)")
    worker.add_argument(
        "--ping",
        action="store_true",
        help="do not start: exit 0 when this host's worker answers a ping (health checks)",
    )
    worker.add_argument("--loglevel", default="INFO", choices=("DEBUG", "INFO", "WARNING"))
    add_settings_arguments(worker)
    worker.set_defaults(func=run_worker)


def run_worker(args: argparse.Namespace) -> int:
    from backend.jobs.celery_runner import make_celery_app

    if args.concurrency < 1:
        raise ValueError(f"--concurrency must be ≥ 1, got {args.concurrency}")
    settings = settings_from_args(args)
    if not settings.broker_url:
        raise ValueError(
            "no broker: set WHEELSCAN_BROKER_URL or --broker-url (redis://host:6379/0)"
        )
    if not settings.database_url:
        raise ValueError(
            "no database: workers need the service's WHEELSCAN_DATABASE_URL or --database-url"
        )
    app = make_celery_app(settings)
    hostname = args.hostname or f"wheelscan@{socket.gethostname()}"
    if args.ping:
        return _ping(app, hostname)
    argv = [
        "worker",
        f"--concurrency={args.concurrency}",
        f"--pool={args.pool}",
        f"--loglevel={args.loglevel}",
        "--without-gossip",
        "--without-mingle",
        f"--hostname={hostname}",
    ]
    sys.stderr.write(
        f"wheelscan worker: {args.concurrency} process(es), broker {settings.broker_url}\n"
    )
    app.worker_main(argv)
    return 0


def _ping(app: Celery, hostname: str) -> int:
    replies = app.control.ping(destination=[hostname], timeout=WORKER_PING_TIMEOUT_S, limit=1)
    if not replies:
        raise OSError(f"worker {hostname} did not answer within {WORKER_PING_TIMEOUT_S} s")
    sys.stdout.write(f"{hostname}: ok\n")
    return 0
