"""The capture loop: wheel-sensor events in, labelled frames into the spool.

Each axle event is labelled (vehicle, axle) by the AxleCounter and handed to one worker
thread per sensor, which grabs `frames_per_wheel` frames from its camera (seq =
axle index × frames_per_wheel + k) and spools them as PNG. A camera that does not deliver
within its timeout, delivers a wrong-sized frame, or finds the buffer full has its frames of
that wheel declared missing with the reason; a lost camera is declared missing at once for
every later wheel, so nothing waits on it. A pass ends on an "end" event, on
`pass_end_gap_s` of silence or when the event stream ends.
"""

from __future__ import annotations

import queue
import threading
import time
from collections import Counter
from collections.abc import Callable
from datetime import UTC, datetime

import cv2
import numpy as np

from backend.agent.axles import (
    AxleCounter,
    AxleEvent,
    AxleLabel,
    EndEvent,
    EventError,
    VehicleTag,
)
from backend.agent.cameras import CameraSource, GrabFailed
from backend.agent.progress import Progress
from backend.agent.spool import PassOpen, Spool
from backend.agent.station import SensorConfig, Station

PNG_PARAMS = (
    cv2.IMWRITE_PNG_COMPRESSION,
    1,
    cv2.IMWRITE_PNG_FILTER,
    cv2.IMWRITE_PNG_FILTER_NONE,
    cv2.IMWRITE_PNG_STRATEGY,
    cv2.IMWRITE_PNG_STRATEGY_HUFFMAN_ONLY,
)
"""No row filter, Huffman coding only: faster than OpenCV's default PNG settings and no
larger (re-measured on a noisy 8-bit 1600×1200 frame with a stripe: 32 instead of 42 ms per
frame, 8 % smaller; the first measurement's 3× is not reproduced)."""
POLL_S = 0.1
TAG_WAIT_S = 1.0
"""How long a new vehicle waits for its tag record before it is numbered instead."""


def encode_png(image: np.ndarray) -> bytes:
    """Lossless PNG of an 8- or 16-bit grey frame, fast (deterministic for equal pixels)."""
    ok, buffer = cv2.imencode(".png", image, PNG_PARAMS)
    if not ok:
        raise ValueError(f"cannot encode a {image.dtype} {image.shape} frame as PNG")
    return buffer.tobytes()


class SensorWorker:
    """Grabs one sensor's frames for each queued axle, in its own thread."""

    def __init__(
        self,
        config: SensorConfig,
        camera: CameraSource | None,
        absent_reason: str | None,
        station: Station,
        spool: Spool,
        progress: Progress,
    ) -> None:
        self.config = config
        self._camera = camera
        self._lost_reason = absent_reason
        self._station = station
        self._spool = spool
        self._progress = progress
        self._queue: queue.Queue[tuple[str, AxleLabel] | None] = queue.Queue()
        self.on_axle_done: Callable[[str, AxleLabel], None] = lambda _key, _label: None
        self._thread = threading.Thread(target=self._run, name=f"camera {config.sensor}")
        self._thread.start()

    def submit(self, key: str, label: AxleLabel) -> None:
        """Queue one triggered axle."""
        self._queue.put((key, label))

    def wait_idle(self) -> None:
        """Wait until every queued axle is spooled or declared missing."""
        self._queue.join()

    def stop(self) -> None:
        """Finish the queue and end the thread."""
        self._queue.put(None)
        self._thread.join()

    def _run(self) -> None:
        while (job := self._queue.get()) is not None:
            try:
                self._capture(*job)
            except Exception as exc:  # e.g. the spool's disk failing: say so, keep going
                self._progress.warn(f"{self.config.sensor}: frames of a wheel lost: {exc!r}")
            finally:
                self.on_axle_done(*job)
                self._queue.task_done()
        self._queue.task_done()

    def _capture(self, key: str, label: AxleLabel) -> None:
        frames = self._station.frames_per_wheel
        if self._lost_reason is not None or self._camera is None:
            self._declare(key, label, self._lost_reason or "no camera")
            return
        for k in range(frames):
            try:
                image = self._camera.grab()
            except GrabFailed as exc:
                if exc.lost:
                    self._lost_reason = f"{exc.reason} (camera lost)"
                suffix = f" (after {k} of {frames} frames)" if k else ""
                self._declare(key, label, exc.reason + suffix)
                return
            problem = self._check(image)
            if problem is not None:
                self._declare(key, label, problem)
                return
            png = encode_png(image)
            seq = label.index * frames + k
            sensor = self.config.sensor
            if not self._spool.add_frame(key, sensor, seq, label.vehicle_id, label.axle, png):
                mb = self._spool.limit_bytes / 2**20
                self._declare(key, label, f"agent's local buffer full ({mb:.0f} MB)")
                self._progress.frame_refused(sensor)
                return
            self._progress.frame_captured(sensor)

    def _check(self, image: np.ndarray) -> str | None:
        expected = (self._station.image_height_px, self._station.image_width_px)
        dtype = np.uint8 if self.config.pixel_format == "Mono8" else np.uint16
        if image.shape != expected or image.dtype != dtype:
            return (
                f"camera {self.config.camera} delivered a {image.dtype} {image.shape[::-1]} frame,"
                f" expected {np.dtype(dtype)} {expected[::-1]}"
            )
        return None

    def _declare(self, key: str, label: AxleLabel, reason: str) -> None:
        config = self.config
        self._spool.add_missing(
            key, label.vehicle_id, label.axle, config.side, config.sensor, reason
        )
        self._progress.frame_missing(config.sensor)


class Capture:
    """Turns the wheel-sensor event stream into spooled, labelled passes.

    Parameters
    ----------
    station : Station
    workers : list of SensorWorker
        One per sensor of the station.
    spool : Spool
    progress : Progress
    calibration : dict or None
        Sent with each pass's open request (None: the site's registered calibration).
    """

    def __init__(
        self,
        station: Station,
        workers: list[SensorWorker],
        spool: Spool,
        progress: Progress,
        calibration: dict[str, object] | None,
    ) -> None:
        self._station = station
        self._workers = workers
        self._spool = spool
        self._progress = progress
        self._calibration = calibration
        self._key: str | None = None
        self._counter = AxleCounter(station.axles_per_vehicle)
        self._tags_ended = False
        self._axle_lock = threading.Lock()
        self._axle_workers: Counter[tuple[str, int]] = Counter()
        self.passes = 0
        for worker in workers:
            worker.on_axle_done = self._axle_done

    def run(
        self,
        events: queue.Queue[object],
        tags: queue.Queue[object] | None,
        stop: threading.Event,
    ) -> None:
        """Process events until the stream ends or `stop` is set; the last pass is ended.

        A bad event line is reported and skipped; raises the OSError that ended the
        wheel-sensor stream, if any.
        """
        last_event_s = time.monotonic()
        try:
            while not stop.is_set():
                try:
                    event = events.get(timeout=POLL_S)
                except queue.Empty:
                    if time.monotonic() - last_event_s >= self._station.pass_end_gap_s:
                        self._end_pass()
                    continue
                last_event_s = time.monotonic()
                if event is None:
                    return
                if isinstance(event, EventError):
                    self._progress.warn(f"wheel sensor: {event}; line ignored")
                elif isinstance(event, BaseException):
                    raise event
                if isinstance(event, EndEvent):
                    self._end_pass()
                elif isinstance(event, AxleEvent):
                    self._axle(event, tags)
        finally:
            self._end_pass()

    def _axle(self, event: AxleEvent, tags: queue.Queue[object] | None) -> None:
        if self._key is None:
            request = PassOpen(
                site=self._station.site,
                started_at=datetime.now(UTC).isoformat(),
                direction=self._station.direction,
                speed_kmh=event.speed_kmh,
                frames_per_sensor=self._station.frames_per_wheel,
                calibration=self._calibration,
            )
            self._key = self._spool.begin_pass(request)
            self._counter = AxleCounter(self._station.axles_per_vehicle)
            self.passes += 1
        label = self._counter.count_axle(lambda: self._take_tag(tags))
        with self._axle_lock:
            self._axle_workers[(self._key, label.index)] = len(self._workers)
        for worker in self._workers:
            worker.submit(self._key, label)

    def _axle_done(self, key: str, label: AxleLabel) -> None:
        with self._axle_lock:
            self._axle_workers[(key, label.index)] -= 1
            done = self._axle_workers[(key, label.index)] == 0
            if done:
                del self._axle_workers[(key, label.index)]
        if done:
            self._spool.release_axle(key, label.vehicle_id, label.axle)

    def _take_tag(self, tags: queue.Queue[object] | None) -> VehicleTag | None:
        while tags is not None and not self._tags_ended:
            try:
                item = tags.get(timeout=TAG_WAIT_S)
            except queue.Empty:
                return None
            if item is None:
                self._tags_ended = True
            elif isinstance(item, VehicleTag):
                return item
            else:
                self._progress.warn(f"tag reader: {item}")
        return None

    def _end_pass(self) -> None:
        if self._key is None:
            return
        for worker in self._workers:
            worker.wait_idle()
        self._spool.end_pass(self._key)
        self._key = None
