"""One agent run: cameras, capture, spool and uploader wired together.

`run_agent` checks the token, opens the cameras, starts the uploader (which first resumes
whatever an earlier run left in the spool), runs the capture loop until the wheel-sensor
stream ends (or `stop` is set) and then waits until every pass is closed on the server.
"""

from __future__ import annotations

import json
import queue
import threading
from collections.abc import Callable
from dataclasses import dataclass

from backend.agent.axles import parse_tag, parse_wheel_event, start_reader
from backend.agent.cameras import CameraSource, open_cameras
from backend.agent.capture import Capture, SensorWorker
from backend.agent.client import RequestRejected, ServerUnavailable, StreamClient
from backend.agent.progress import MIB, Progress
from backend.agent.spool import Spool
from backend.agent.station import Station
from backend.agent.uploader import Uploader

TICK_S = 0.25


@dataclass(frozen=True, slots=True)
class AgentSummary:
    """What one run did."""

    passes: int
    frames_captured: int
    frames_missing: int
    frames_sent: int
    wheels_sent: int
    passes_closed: int


def run_agent(
    station: Station,
    server: str,
    token: str,
    *,
    allow_missing_cameras: bool,
    sink: Callable[[str], None],
    on_tick: Callable[[Progress], None],
    stop: threading.Event,
    cameras: dict[str, CameraSource] | None = None,
) -> AgentSummary:
    """Run the agent until the wheel-sensor stream ends and the spool is drained.

    Parameters
    ----------
    station : Station
    server, token : str
        Server base URL and operator token.
    allow_missing_cameras : bool
        Run with the cameras found, declaring the others' frames missing, instead of failing.
    sink : callable
        Receives warning and status lines.
    on_tick : callable
        Called about every TICK_S with the progress counters.
    stop : threading.Event
        Set to end capture early (the spool keeps what is not sent).
    cameras : dict of sensor → CameraSource, optional
        Already opened cameras (default: open the station's cameras with pypylon).

    Raises
    ------
    TokenRefused, CameraError, StationError, EventError, ValueError
        One-line messages for the CLI.
    """
    calibration = _load_calibration(station)
    _check_token(server, token, sink)
    spool = Spool(station.spool_dir, int(station.spool_limit_mb * MIB))
    if spool.waiting():
        sink(f"resuming {spool.waiting()} buffered items from {station.spool_dir}")
    names = tuple(s.sensor for s in station.sensors)
    progress = Progress(names, station.frames_per_wheel, spool, sink)
    missing: dict[str, str] = {}
    if cameras is None:
        cameras, missing = open_cameras(station, allow_missing=allow_missing_cameras)
    for reason in missing.values():
        sink(f"warning: {reason}; its frames are declared missing")
    workers = [
        SensorWorker(c, cameras.get(c.sensor), missing.get(c.sensor), station, spool, progress)
        for c in station.sensors
    ]
    uploader = Uploader(
        spool, lambda: StreamClient(server, token), station.upload_workers, progress
    )
    capture = Capture(station, workers, spool, progress, calibration)
    try:
        uploader.start()
        _capture_until_done(station, capture, uploader, progress, on_tick, stop)
        while not stop.is_set() and not uploader.stopped and not spool.wait_drained(TICK_S):
            on_tick(progress)
        on_tick(progress)
    finally:
        stop.set()
        for worker in workers:
            worker.stop()
        for camera in cameras.values():
            camera.close()
        uploader.stop()
    if uploader.fatal is not None:
        raise uploader.fatal
    return AgentSummary(
        capture.passes,
        sum(progress.captured.values()),
        sum(progress.missing.values()),
        progress.frames_sent,
        progress.wheels_sent,
        progress.passes_closed,
    )


def _capture_until_done(
    station: Station,
    capture: Capture,
    uploader: Uploader,
    progress: Progress,
    on_tick: Callable[[Progress], None],
    stop: threading.Event,
) -> None:
    events: queue.Queue[object] = queue.Queue()
    start_reader(station.wheel_sensor_source, parse_wheel_event, events, stop)
    tags: queue.Queue[object] | None = None
    if station.tag_reader_source is not None:
        tags = queue.Queue()
        start_reader(station.tag_reader_source, parse_tag, tags, stop)
    failure: list[BaseException] = []

    def run() -> None:
        try:
            capture.run(events, tags, stop)
        except BaseException as exc:  # handed to the caller's thread below
            failure.append(exc)

    thread = threading.Thread(target=run, name="capture")
    thread.start()
    try:
        while thread.is_alive():
            thread.join(TICK_S)
            on_tick(progress)
            if uploader.stopped:
                stop.set()
    except BaseException:
        # An interrupt (Ctrl-C) or a failing tick: the capture loop must end before the
        # cameras' workers are stopped, or an axle it queues after their stop is never
        # grabbed and its end of pass waits for it for ever (the process would not exit).
        # The loop notices `stop` within POLL_S; the axles already triggered are finished.
        stop.set()
        thread.join()
        raise
    if failure:
        raise failure[0]


def _check_token(server: str, token: str, sink: Callable[[str], None]) -> None:
    client = StreamClient(server, token, timeout_s=10.0)
    try:
        client.check_token()
    except ServerUnavailable as exc:
        sink(f"warning: {exc}; buffering frames until it answers")
    except RequestRejected as exc:
        if exc.status != 404:
            raise
    finally:
        client.close()


def _load_calibration(station: Station) -> dict[str, object] | None:
    if station.calibration is None:
        return None
    try:
        data = json.loads(station.calibration.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError) as exc:
        raise ValueError(f"calibration {station.calibration}: cannot read JSON ({exc})") from None
    if not isinstance(data, dict):
        raise ValueError(f"calibration {station.calibration}: must be a JSON object")
    return data
