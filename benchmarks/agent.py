"""Frames per second the capture agent sustains: emulated cameras → spool → local server.

A simulated 4-vehicle pass (16 axles, 32 wheels, one 1600×1200 frame per sensor and wheel:
64 frames, 16 per camera) is replayed by four pylon emulated cameras, software-triggered
as fast as the agent takes axle events (all events are queued at once, so the figure is
what the agent sustains, not what a train asks of it). Three runs:

- the emulated cameras alone (their own cost: the emulator decodes a PNG per grab, which a
  real camera does not);
- capture only: cameras → PNG → disk spool (no server);
- capture and stream: the whole agent (`run_agent`) to the real server (uvicorn subprocess,
  SQLite, measuring wheels as they complete), the clock stopped when the pass is closed.

A Basler acA1600-60gm delivers at most 60 frames/s per camera (240/s for the station).

Run alone with `python -m benchmarks.agent` (prints the Markdown section).
"""

from __future__ import annotations

import os
import queue
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from pathlib import Path

from backend.agent.axles import parse_tag, parse_wheel_event, start_reader
from backend.agent.cameras import CameraSource, open_cameras
from backend.agent.capture import Capture, SensorWorker
from backend.agent.progress import Progress
from backend.agent.replay import write_replay_station
from backend.agent.runner import run_agent
from backend.agent.spool import Spool
from backend.agent.station import Station, load_station
from tests.backend.agent.live_server import LiveServer

VEHICLES = 4
CAMERA_LIMIT_FPS = 60.0
CAMERAS = 4


def _simulate(out: Path) -> Path:
    command = [sys.executable, "-m", "backend.cli", "synth-pass", str(out), "--field", "clean"]
    subprocess.run([*command, "--vehicles", str(VEHICLES)], check=True, capture_output=True)
    return out


def _grab_only(station: Station, frames_per_camera: int) -> tuple[int, float]:
    """The emulated cameras alone: one thread per camera grabbing its frames."""
    cameras, _ = open_cameras(station, allow_missing=False)

    def grab_all(camera: CameraSource) -> None:
        for _ in range(frames_per_camera):
            camera.grab()

    threads = [threading.Thread(target=grab_all, args=(c,)) for c in cameras.values()]
    start = time.perf_counter()
    try:
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
        elapsed = time.perf_counter() - start
    finally:
        for camera in cameras.values():
            camera.close()
    return frames_per_camera * len(cameras), elapsed


def _capture_only(station: Station) -> tuple[int, float]:
    spool = Spool(station.spool_dir, int(station.spool_limit_mb * 2**20))
    sensors = tuple(s.sensor for s in station.sensors)
    progress = Progress(sensors, station.frames_per_wheel, spool, lambda _line: None)
    cameras, _ = open_cameras(station, allow_missing=False)
    workers = [
        SensorWorker(c, cameras[c.sensor], None, station, spool, progress) for c in station.sensors
    ]
    stop = threading.Event()
    events: queue.Queue[object] = queue.Queue()
    tags: queue.Queue[object] = queue.Queue()
    start = time.perf_counter()
    start_reader(station.wheel_sensor_source, parse_wheel_event, events, stop)
    start_reader(str(station.tag_reader_source), parse_tag, tags, stop)
    try:
        Capture(station, workers, spool, progress, None).run(events, tags, stop)
        elapsed = time.perf_counter() - start
    finally:
        for worker in workers:
            worker.stop()
        for camera in cameras.values():
            camera.close()
    return sum(progress.captured.values()), elapsed


def _capture_and_stream(station: Station, server: LiveServer) -> tuple[int, float]:
    cameras, _ = open_cameras(station, allow_missing=False)
    start = time.perf_counter()
    summary = run_agent(
        station,
        server.url,
        server.tokens["operator"],
        allow_missing_cameras=False,
        sink=lambda _line: None,
        on_tick=lambda _progress: None,
        stop=threading.Event(),
        cameras=cameras,
    )
    elapsed = time.perf_counter() - start
    if summary.passes_closed != 1 or summary.frames_sent != summary.frames_captured:
        raise RuntimeError(f"agent run incomplete: {summary}")
    return summary.frames_sent, elapsed


def _measured(run_once: Callable[[], tuple[int, float]]) -> tuple[int, float, float]:
    """Frames, wall seconds and this process's CPU seconds (all threads) of one run."""
    cpu_start = time.process_time()
    frames, elapsed_s = run_once()
    return frames, elapsed_s, time.process_time() - cpu_start


def _row(name: str, frames: int, elapsed_s: float, cpu_s: float) -> str:
    fps = frames / elapsed_s
    per_camera = fps / CAMERAS
    return (
        f"| {name} | {frames} | {elapsed_s:.2f} | {fps:.1f} | {per_camera:.1f} | "
        f"{per_camera / CAMERA_LIMIT_FPS:.0%} | {cpu_s / frames * 1000:.0f} |"
    )


def run() -> str:
    """Measure and return the Markdown section."""
    os.environ["PYLON_CAMEMU"] = str(CAMERAS)
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        archive = _simulate(root / "pass")
        grab_station = load_station(write_replay_station(archive, root / "grab"))
        per_camera = len(list((root / "grab" / "replay" / "left_inner").glob("*.png")))
        grab = _measured(lambda: _grab_only(grab_station, per_camera))
        capture_station = load_station(write_replay_station(archive, root / "capture"))
        capture = _measured(lambda: _capture_only(capture_station))
        server = LiveServer(root / "data")
        server.start()
        try:
            stream_station = load_station(write_replay_station(archive, root / "stream"))
            stream = _measured(lambda: _capture_and_stream(stream_station, server))
        finally:
            server.stop()
    lines = [
        "## Capture agent: frames per second to a local server",
        "",
        f"Simulated {VEHICLES}-vehicle pass, 1600×1200 8-bit frames, {CAMERAS} pylon emulated "
        "cameras replaying it (the emulator decodes each PNG per grab), software-triggered as "
        "fast as the agent goes. The camera limit is 60 frames/s per camera. CPU ms/frame "
        "is the agent process's CPU time (all threads, emulator included; not the server's) "
        "per frame: the machine is shared, so wall-clock rates depend on its load "
        f"(1-min load average at the end: {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores).",
        "",
        "| run | frames | seconds | frames/s | per camera | of camera limit | CPU ms/frame |",
        "|---|---:|---:|---:|---:|---:|---:|",
        _row("emulated cameras alone (grab, no agent work)", *grab),
        _row("capture only (cameras → PNG → disk spool)", *capture),
        _row("capture + stream to the server (pass closed)", *stream),
    ]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    sys.stdout.write(run())
