"""The capture loop with emulated cameras replaying a pass: labels come from the trigger
sequence (the manifest's axle order as software triggers), pixels from the cameras."""

from __future__ import annotations

import json
import os
import queue
import threading
import time
from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from backend.agent.axles import AxleEvent, parse_tag, parse_wheel_event, start_reader
from backend.agent.cameras import open_cameras
from backend.agent.capture import Capture, SensorWorker, encode_png
from backend.agent.progress import Progress
from backend.agent.replay import write_replay_station
from backend.agent.spool import FrameItem, MissingItem, Spool
from backend.agent.station import load_station
from pipeline.archive.pass_archive import read_pass_archive
from tests.backend.agent.conftest import make_archive


def capture_into_spool(
    station_path: Path, *, allow_missing: bool = False, limit_bytes: int = 64 * 2**20
) -> tuple[Spool, list[str]]:
    """Run the capture loop over the station's event files; return the spool and warnings."""
    station = load_station(station_path)
    spool = Spool(station.spool_dir, limit_bytes)
    warnings: list[str] = []
    progress = Progress(tuple(s.sensor for s in station.sensors), 2, spool, warnings.append)
    cameras, missing = open_cameras(station, allow_missing=allow_missing)
    workers = [
        SensorWorker(c, cameras.get(c.sensor), missing.get(c.sensor), station, spool, progress)
        for c in station.sensors
    ]
    stop = threading.Event()
    events: queue.Queue[object] = queue.Queue()
    tags: queue.Queue[object] = queue.Queue()
    start_reader(station.wheel_sensor_source, parse_wheel_event, events, stop)
    start_reader(station.tag_reader_source, parse_tag, tags, stop)
    try:
        Capture(station, workers, spool, progress, None).run(events, tags, stop)
    finally:
        for worker in workers:
            worker.stop()
        for camera in cameras.values():
            camera.close()
    return spool, warnings


def drain(spool: Spool) -> list[tuple[FrameItem | MissingItem, bytes]]:
    """Everything spooled, acknowledged as a server would (frames with their PNG bytes)."""
    items = []
    while isinstance(item := spool.take(0), FrameItem | MissingItem):
        items.append((item, item.path.read_bytes() if isinstance(item, FrameItem) else b""))
        spool.ack(item)
    return items


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
def test_replayed_pass_is_spooled_with_the_manifests_labels_and_pixels(
    tmp_path: Path, emulated_cameras: int, dtype: type
) -> None:
    archive_dir, frames = make_archive(tmp_path / "pass", dtype=dtype)
    station_path = write_replay_station(archive_dir, tmp_path / "station")
    spool, warnings = capture_into_spool(station_path)
    items = drain(spool)
    assert all(isinstance(i, FrameItem) for i, _ in items), warnings
    manifest = read_pass_archive(archive_dir, decode_frames=False).manifest
    expected = {}
    for wheel in manifest.wheels:
        for position in ("inner", "outer"):
            for path in wheel.frames(position):
                expected[(wheel.vehicle_id, wheel.axle, wheel.sensor_name(position), path)] = None
    got = {}
    for item, png in items:
        image = cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_UNCHANGED)
        got[(item.vehicle_id, item.axle, item.sensor)] = got.get(
            (item.vehicle_id, item.axle, item.sensor), []
        ) + [(item.seq, image)]
    assert len(items) == len(expected) == 32
    for vehicle, axle, sensor, path in expected:
        seqs_images = sorted(got[(vehicle, axle, sensor)], key=lambda p: p[0])
        k = int(path.rsplit("-", 1)[1].removesuffix(".png"))
        seq, image = seqs_images[k]
        axle_index = manifest.vehicles.index(vehicle) * 2 + axle - 1
        assert seq == axle_index * 2 + k
        assert image.dtype == dtype
        np.testing.assert_array_equal(image, frames[path])


def test_a_camera_not_attached_has_its_frames_declared_missing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("PYLON_CAMEMU", "3")
    archive_dir, _ = make_archive(tmp_path / "pass", vehicles=("v",), axles=2)
    station_path = write_replay_station(archive_dir, tmp_path / "station")
    spool, _ = capture_into_spool(station_path, allow_missing=True)
    items = [item for item, _ in drain(spool)]
    missing = [i for i in items if isinstance(i, MissingItem)]
    assert [(m.vehicle_id, m.axle, m.side, m.sensor) for m in missing] == [
        ("v", 1, "right", "right_outer"),
        ("v", 2, "right", "right_outer"),
    ]
    assert missing[0].reason == "camera '0815-0003' for right_outer is not attached"
    frames = [i for i in items if isinstance(i, FrameItem)]
    assert {f.sensor for f in frames} == {"left_inner", "left_outer", "right_inner"}
    assert len(frames) == 3 * 2 * 2


def test_a_camera_that_never_fires_times_out_per_wheel_and_the_pass_goes_on(
    tmp_path: Path, emulated_cameras: int
) -> None:
    archive_dir, _ = make_archive(tmp_path / "pass", vehicles=("v",), axles=2)
    station_path = write_replay_station(archive_dir, tmp_path / "station")
    data = json.loads(station_path.read_text())
    data["sensors"]["left_outer"]["trigger_source"] = "Line1"
    data["sensors"]["left_outer"]["timeout_s"] = 0.05
    station_path.write_text(json.dumps(data))
    spool, _ = capture_into_spool(station_path)
    items = [item for item, _ in drain(spool)]
    missing = [i for i in items if isinstance(i, MissingItem)]
    assert [(m.axle, m.sensor) for m in missing] == [(1, "left_outer"), (2, "left_outer")]
    assert "left_outer (0815-0001) delivered no frame within 0.05 s" in missing[0].reason
    assert sum(isinstance(i, FrameItem) for i in items) == 3 * 2 * 2


@settings(max_examples=25, deadline=None)
@given(
    st.sampled_from([np.uint8, np.uint16]),
    st.integers(1, 40),
    st.integers(1, 40),
    st.integers(0, 2**32 - 1),
)
def test_frame_encoding_is_lossless_and_deterministic(
    dtype: type, rows: int, cols: int, seed: int
) -> None:
    image = np.random.default_rng(seed).integers(0, np.iinfo(dtype).max + 1, (rows, cols))
    image = image.astype(dtype)
    png = encode_png(image)
    decoded = cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_UNCHANGED)
    assert decoded.dtype == dtype
    np.testing.assert_array_equal(decoded, image)
    assert encode_png(image.copy()) == png


def test_a_full_buffer_warns_first_then_declares_frames_missing(
    tmp_path: Path, emulated_cameras: int
) -> None:
    archive_dir, _ = make_archive(tmp_path / "pass", vehicles=("v",), axles=2)
    station_path = write_replay_station(archive_dir, tmp_path / "station")
    first = tmp_path / "station" / "replay" / "left_inner" / "000000.png"
    frame_bytes = len(encode_png(cv2.imread(str(first), cv2.IMREAD_UNCHANGED)))
    spool, warnings = capture_into_spool(station_path, limit_bytes=12 * frame_bytes)
    items = [item for item, _ in drain(spool)]
    frames = [i for i in items if isinstance(i, FrameItem)]
    missing = [i for i in items if isinstance(i, MissingItem)]
    assert 0 < len(frames) < 16
    assert missing and all(m.reason.startswith("agent's local buffer full") for m in missing)
    nearly = [w for w in warnings if "local buffer nearly full" in w]
    full = [w for w in warnings if "local buffer full: new frames are declared missing" in w]
    assert len(nearly) == 1 and len(full) == 1
    assert warnings.index(nearly[0]) < warnings.index(full[0])


def test_a_camera_lost_mid_pass_is_declared_missing_at_once_for_later_wheels(
    tmp_path: Path, emulated_cameras: int
) -> None:
    archive_dir, _ = make_archive(tmp_path / "pass", vehicles=("v",), axles=3)
    station = load_station(write_replay_station(archive_dir, tmp_path / "station"))
    spool = Spool(station.spool_dir, 64 * 2**20)
    progress = Progress(tuple(s.sensor for s in station.sensors), 2, spool, lambda _line: None)
    cameras, _ = open_cameras(station, allow_missing=False)
    workers = [
        SensorWorker(c, cameras[c.sensor], None, station, spool, progress) for c in station.sensors
    ]
    events: queue.Queue[object] = queue.Queue()
    capture = Capture(station, workers, spool, progress, None)
    thread = threading.Thread(target=capture.run, args=(events, None, threading.Event()))
    thread.start()
    try:
        events.put(AxleEvent())
        deadline = time.monotonic() + 60
        while progress.captured["right_outer"] < 2:
            assert time.monotonic() < deadline
            time.sleep(0.01)
        cameras["right_outer"].close()  # the device goes away between two wheels
        events.put(AxleEvent())
        events.put(AxleEvent())
        events.put(None)
        thread.join()
    finally:
        for worker in workers:
            worker.stop()
        for camera in cameras.values():
            camera.close()
    items = [item for item, _ in drain(spool)]
    missing = [i for i in items if isinstance(i, MissingItem)]
    assert [(m.axle, m.sensor) for m in missing] == [(2, "right_outer"), (3, "right_outer")]
    assert "right_outer (0815-0003) failed" in missing[0].reason
    assert missing[1].reason.endswith("(camera lost)")
    assert sum(isinstance(i, FrameItem) for i in items) == 3 * 2 * 3 + 2


def test_an_interrupt_ends_capture_before_the_camera_workers_and_leaves_no_thread(
    tmp_path: Path, emulated_cameras: int
) -> None:
    """Ctrl-C while axles are still arriving: run_agent re-raises it only after the capture
    loop has ended its pass (the axles already triggered are grabbed and spooled), so no
    axle is queued to a stopped camera worker and no thread is left for the process to
    wait on at exit (the agent once hung after SIGINT with the server down)."""
    from backend.agent.runner import run_agent

    vehicles = tuple(f"80-{n:02d}" for n in range(12))
    archive_dir, _ = make_archive(tmp_path / "pass", vehicles=vehicles)
    station = load_station(write_replay_station(archive_dir, tmp_path / "station"))
    events = tmp_path / "station" / "axles.jsonl"
    lines = events.read_text().splitlines(keepends=True)
    events.unlink()
    os.mkfifo(events)

    def trigger_slowly() -> None:  # a train at speed: one axle every 40 ms
        with open(events, "w", encoding="utf-8") as fifo:
            for line in lines:
                fifo.write(line)
                fifo.flush()
                time.sleep(0.04)

    threading.Thread(target=trigger_slowly, daemon=True).start()
    said: list[str] = []

    def interrupt_once_frames_are_spooled(progress: Progress) -> None:
        if sum(progress.captured.values()) > 0:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_agent(
            station,
            "http://127.0.0.1:9",  # nothing listens: the agent buffers
            "token",
            allow_missing_cameras=False,
            sink=said.append,
            on_tick=interrupt_once_frames_are_spooled,
            stop=threading.Event(),
        )
    left = [t.name for t in threading.enumerate() if t.name == "capture" or "camera" in t.name]
    assert left == [], left
    items = drain(Spool(station.spool_dir, 64 * 2**20))
    per_axle = 4 * station.frames_per_wheel  # four sensors
    assert 0 < len(items) < len(vehicles) * 2 * per_axle, said
    assert len(items) % per_axle == 0  # every triggered axle grabbed whole
