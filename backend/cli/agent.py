"""`wheelscan agent` (the station capture agent) and `wheelscan agent-replay` (its demo set-up)."""

from __future__ import annotations

import argparse
import faulthandler
import signal
import sys
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from types import FrameType

from tqdm import tqdm

from backend.agent.station import check_server_url, load_station
from backend.config import Settings


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the `agent` and `agent-replay` verbs."""
    agent = subparsers.add_parser(
        "agent",
        help="stream frames from the station's cameras to the server",
        description="Open the station's cameras, label each triggered wheel's frames "
        "(vehicle, axle, side) and stream them into passes on the server, buffering on "
        "local disk while the server is away.",
    )
    agent.add_argument("--server", help="server URL (default: the station file's 'server')")
    agent.add_argument("--token", help="operator token (default: WHEELSCAN_TOKEN)")
    agent.add_argument("--station", required=True, type=Path, help="station file (.toml/.json)")
    agent.add_argument(
        "--allow-missing-cameras",
        action="store_true",
        help="run with the cameras found; the others' frames are declared missing",
    )
    agent.set_defaults(func=run_agent_verb)
    replay = subparsers.add_parser(
        "agent-replay",
        help="write an emulated-camera station that replays a pass archive",
        description="Write replay folders, wheel-sensor and tag events and a station file "
        "for pylon's emulated cameras from a pass archive; then run "
        "`PYLON_CAMEMU=4 wheelscan agent --station OUT/station.json ...`.",
    )
    replay.add_argument("archive", type=Path, help="pass archive (folder or .zip)")
    replay.add_argument("out", type=Path, help="folder to write the station into")
    replay.set_defaults(func=run_replay_verb)


class Terminated(KeyboardInterrupt):
    """SIGTERM (a service manager stopping the agent): the run ends as on Ctrl-C, with
    `exit_status` 143 (128 + SIGTERM) and `message` "terminated"."""

    exit_status = 128 + signal.SIGTERM
    message = "terminated"


def run_agent_verb(args: argparse.Namespace) -> int:
    """Run the agent until its wheel-sensor stream ends and everything is sent.

    SIGUSR1 writes every thread's stack to stderr (for a hung agent; the process goes on).
    """
    if hasattr(signal, "SIGUSR1"):
        faulthandler.register(signal.SIGUSR1, all_threads=True)
    with interrupt_requests() as interrupted:
        return _run_agent(args, interrupted)


@contextmanager
def interrupt_requests() -> Iterator[Callable[[], int]]:
    """Make Ctrl-C (SIGINT) and SIGTERM requests that the run's ticks turn into
    KeyboardInterrupt (`Terminated` for SIGTERM).

    Yields a callable giving the first signal asked for (0: none). Python raises
    KeyboardInterrupt wherever the main thread happens to be, and C code that clears errors
    loses it: pypylon's module start-up does (a Ctrl-C while `open_cameras` imports it was
    dropped and the agent, its server away, ran on for ever). The handler only records the
    request, so nothing can drop it; `on_tick` (every TICK_S = 0.25 s, from the capture loop
    on) raises the exception where run_agent ends capture and its threads in order, its
    spool kept for the next run. A second signal of the same kind acts at once, as usual
    (KeyboardInterrupt, or the default SIGTERM: the process ends).

    SIGTERM is what a service manager (systemd's stop) and `kill` send; it used to end the
    agent at once, its cameras not closed and its capture and upload threads not stopped
    in order (`run_agent`'s `finally`).

    An ignored SIGINT is taken over too: a shell without job control starts a background
    command (`wheelscan agent ... &` in a script, a test run started so) with SIGINT
    ignored, exec keeps it ignored and Python leaves it so; the agent then never saw Ctrl-C
    or `kill -INT` and, its server away, buffered for ever. The previous dispositions are
    restored on exit; nothing is installed outside the main thread or where another handler
    is in place.
    """
    requests: list[int] = []
    # Per signal, the dispositions taken over; the first, its default, is the one a second
    # signal of it meets.
    over: dict[int, tuple[Callable[[int, FrameType | None], object] | signal.Handlers, ...]] = {
        signal.SIGINT: (signal.default_int_handler, signal.SIG_IGN),
        signal.SIGTERM: (signal.SIG_DFL,),
    }

    def on_signal(signum: int, _frame: FrameType | None) -> None:
        requests.append(signum)  # no lock, no exception: safe at any point of the main thread
        signal.signal(signum, over[signum][0])

    previous = {signum: signal.getsignal(signum) for signum in over}
    main = threading.current_thread() is threading.main_thread()
    installed = [s for s in over if main and previous[s] in over[s]]
    for signum in installed:
        signal.signal(signum, on_signal)
    try:
        yield lambda: requests[0] if requests else 0
    finally:
        for signum in installed:
            signal.signal(signum, previous[signum])


def _run_agent(args: argparse.Namespace, interrupted: Callable[[], int]) -> int:
    from backend.agent.runner import run_agent

    station = load_station(args.station)
    server = args.server or station.server
    if server is None:
        raise ValueError("no server: give --server URL or 'server' in the station file")
    server = check_server_url(server)
    token = Settings().token if args.token is None else args.token
    if not token:
        raise ValueError("no token: give --token T or set WHEELSCAN_TOKEN")
    bar = tqdm(unit="frame", desc="frames sent", file=sys.stderr, dynamic_ncols=True)

    def on_tick(progress: object) -> None:
        asked = interrupted()
        if asked:
            raise Terminated if asked == signal.SIGTERM else KeyboardInterrupt
        bar.n = progress.frames_sent  # type: ignore[attr-defined]
        bar.set_postfix_str(progress.status(), refresh=True)  # type: ignore[attr-defined]

    try:
        summary = run_agent(
            station,
            server,
            token,
            allow_missing_cameras=args.allow_missing_cameras,
            sink=lambda line: tqdm.write(line, file=sys.stderr),
            on_tick=on_tick,
            stop=threading.Event(),
        )
    finally:
        bar.close()
    sys.stdout.write(
        f"{summary.passes} passes, {summary.frames_captured} frames captured, "
        f"{summary.frames_missing} declared missing, {summary.frames_sent} sent, "
        f"{summary.wheels_sent} wheels sent, {summary.passes_closed} passes closed\n"
    )
    return 0


def run_replay_verb(args: argparse.Namespace) -> int:
    """Write the emulated-camera station of a pass archive."""
    from backend.agent.replay import write_replay_station

    path = write_replay_station(args.archive, args.out)
    sys.stdout.write(f"{path}\n")
    return 0
