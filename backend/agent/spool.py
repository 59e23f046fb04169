"""The local disk buffer between the cameras and the server.

Every captured frame and every missing-frame declaration is written here first and deleted
only when the server has acknowledged it, so a dropped connection (or an agent restart)
loses nothing: the uploader drains the spool when the server is back. The buffer is
bounded by bytes of frames waiting; a frame that does not fit is refused (the capture loop
then declares it missing with the reason) rather than stalling the cameras.

Layout: one folder per pass, ``pass.json`` (the open request, the server's pass id once
known, whether capture has ended), ``f-<sensor>-<seq>.png`` with its ``.json`` labels, and
``m-<n>.json`` missing declarations. A ``.json`` is written after its ``.png``, atomically,
so a half-written frame is never uploaded.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import threading
from collections import Counter, deque
from dataclasses import asdict, dataclass
from pathlib import Path


@dataclass(frozen=True, slots=True)
class PassOpen:
    """The open request of one pass (the body of POST /api/passes/stream)."""

    site: str
    started_at: str
    direction: str | None
    speed_kmh: float | None
    frames_per_sensor: int
    calibration: dict[str, object] | None


@dataclass(frozen=True, slots=True)
class FrameItem:
    """A frame waiting for its PUT."""

    key: str
    sensor: str
    seq: int
    vehicle_id: str
    axle: int
    sha256: str
    nbytes: int
    path: Path


@dataclass(frozen=True, slots=True)
class MissingItem:
    """A missing-frame declaration waiting for its POST."""

    key: str
    vehicle_id: str
    axle: int
    side: str
    sensor: str
    reason: str
    path: Path


@dataclass(frozen=True, slots=True)
class CloseItem:
    """A pass whose capture ended and whose frames and declarations are all acknowledged."""

    key: str


SpoolItem = FrameItem | MissingItem | CloseItem


@dataclass(slots=True)
class _Pass:
    request: PassOpen
    pass_id: int | None
    ended: bool
    outstanding: int
    closing: bool


class Spool:
    """Bounded, persistent, thread-safe queue of what the server has not acknowledged yet.

    Parameters
    ----------
    folder : Path
        Spool folder; passes left there by an earlier run are resumed.
    limit_bytes : int
        Most bytes of frames kept waiting.
    """

    def __init__(self, folder: Path, limit_bytes: int) -> None:
        if limit_bytes < 1:
            raise ValueError(f"limit_bytes must be ≥ 1, got {limit_bytes}")
        self.folder = Path(folder)
        self.limit_bytes = limit_bytes
        self.folder.mkdir(parents=True, exist_ok=True)
        self._lock = threading.Condition()
        self._queue: deque[SpoolItem] = deque()
        self._passes: dict[str, _Pass] = {}
        self._used_bytes = 0
        self._missing_count = 0
        self._declared: set[tuple[str, str, int, str]] = set()
        self._released: set[tuple[str, str, int]] = set()
        self._wheel_frames: Counter[tuple[str, str, int, str]] = Counter()
        for pass_dir in sorted(p for p in self.folder.iterdir() if (p / "pass.json").is_file()):
            self._load_pass(pass_dir)

    @property
    def used_bytes(self) -> int:
        """Bytes of frames waiting."""
        with self._lock:
            return self._used_bytes

    def waiting(self) -> int:
        """Frames and declarations waiting (queued or being sent)."""
        with self._lock:
            return sum(p.outstanding for p in self._passes.values())

    def begin_pass(self, request: PassOpen) -> str:
        """Start spooling a new pass; returns its local key."""
        stem = request.started_at.replace(":", "").replace("-", "").replace("+", "p")
        with self._lock:
            key, n = stem, 1
            while (self.folder / key).exists():
                key, n = f"{stem}-{n}", n + 1
            (self.folder / key).mkdir()
            self._passes[key] = _Pass(request, None, False, 0, False)
            self._write_pass(key)
        return key

    def add_frame(
        self, key: str, sensor: str, seq: int, vehicle_id: str, axle: int, png: bytes
    ) -> bool:
        """Spool one PNG frame; False (nothing stored) when the buffer has no room for it."""
        with self._lock:
            if self._used_bytes + len(png) > self.limit_bytes:
                return False
            self._used_bytes += len(png)
        path = self.folder / key / f"f-{sensor}-{seq:06d}.png"
        item = FrameItem(
            key, sensor, seq, vehicle_id, axle, hashlib.sha256(png).hexdigest(), len(png), path
        )
        path.write_bytes(png)
        labels = {"vehicle_id": vehicle_id, "axle": axle, "sha256": item.sha256}
        _write_json(path.with_suffix(".json"), labels)
        self._enqueue(item)
        return True

    def add_missing(
        self, key: str, vehicle_id: str, axle: int, side: str, sensor: str, reason: str
    ) -> None:
        """Spool a declaration that `sensor` delivered no (or too few) frames of a wheel."""
        with self._lock:
            self._missing_count += 1
            path = self.folder / key / f"m-{self._missing_count:06d}.json"
        item = MissingItem(key, vehicle_id, axle, side, sensor, reason, path)
        body = {"vehicle_id": vehicle_id, "axle": axle, "side": side, "sensor": sensor}
        _write_json(path, {**body, "reason": reason})
        self._enqueue(item)

    def release_axle(self, key: str, vehicle_id: str, axle: int) -> None:
        """Every sensor is done with this axle: its missing declarations may go out (each
        after the frames of its wheel, so no frame arrives at a wheel already settled)."""
        with self._lock:
            self._released.add((key, vehicle_id, axle))
            self._lock.notify_all()

    def end_pass(self, key: str) -> None:
        """Capture of the pass is over: it is closed once everything else is acknowledged."""
        with self._lock:
            self._passes[key].ended = True
            self._write_pass(key)
            self._lock.notify_all()

    def request(self, key: str) -> PassOpen:
        """The open request of a pass."""
        with self._lock:
            return self._passes[key].request

    def pass_id(self, key: str) -> int | None:
        """The server's id of a pass, None until it has been opened."""
        with self._lock:
            return self._passes[key].pass_id

    def set_pass_id(self, key: str, pass_id: int) -> None:
        """Record the server's id of a pass (persisted)."""
        with self._lock:
            self._passes[key].pass_id = pass_id
            self._write_pass(key)

    def waiting_frames(self, key: str) -> list[FrameItem]:
        """Frames of a pass not yet acknowledged and not being sent."""
        with self._lock:
            return [i for i in self._queue if isinstance(i, FrameItem) and i.key == key]

    def take(self, timeout_s: float) -> SpoolItem | None:
        """Claim the oldest waiting item (a CloseItem once its pass is drained), or None."""
        with self._lock:
            self._lock.wait_for(lambda: self._next_item(pop=False) is not None, timeout_s)
            return self._next_item(pop=True)

    def release(self, item: SpoolItem) -> None:
        """Give a claimed item back (its send failed); it is taken again first."""
        with self._lock:
            if isinstance(item, CloseItem):
                self._passes[item.key].closing = False
            else:
                self._queue.appendleft(item)
            self._lock.notify_all()

    def ack(self, item: SpoolItem) -> None:
        """The server has it: delete it from disk (a closed pass's folder goes too)."""
        with self._lock:
            if isinstance(item, CloseItem):
                del self._passes[item.key]
                shutil.rmtree(self.folder / item.key, ignore_errors=True)
            else:
                self._passes[item.key].outstanding -= 1
                if isinstance(item, FrameItem):
                    self._wheel_frames[_wheel(item)] -= 1
                    self._used_bytes -= item.nbytes
                    item.path.unlink(missing_ok=True)
                item.path.with_suffix(".json").unlink(missing_ok=True)
            self._lock.notify_all()

    def ack_where(self, key: str, stored: set[tuple[str, int, str]]) -> int:
        """Acknowledge waiting frames of a pass the server already has as (sensor, seq, sha256)."""
        done = [f for f in self.waiting_frames(key) if (f.sensor, f.seq, f.sha256) in stored]
        with self._lock:
            for item in done:
                self._queue.remove(item)
        for item in done:
            self.ack(item)
        return len(done)

    def wait_drained(self, timeout_s: float) -> bool:
        """Wait until every pass is closed and acknowledged; False on timeout."""
        with self._lock:
            return self._lock.wait_for(lambda: not self._passes, timeout_s)

    def _next_item(self, *, pop: bool) -> SpoolItem | None:
        for item in self._queue:
            if isinstance(item, FrameItem) or (
                isinstance(item, MissingItem) and self._may_declare(item)
            ):
                if pop:
                    self._queue.remove(item)
                return item
        for key, state in self._passes.items():
            if state.ended and state.outstanding == 0 and not state.closing:
                if pop:
                    state.closing = True
                return CloseItem(key)
        return None

    def is_declared(self, item: FrameItem) -> bool:
        """True when the frame's wheel has a missing-frame declaration (it is not measured)."""
        with self._lock:
            return _wheel(item) in self._declared

    def _may_declare(self, item: MissingItem) -> bool:
        ended = self._passes[item.key].ended
        released = ended or (item.key, item.vehicle_id, item.axle) in self._released
        return released and self._wheel_frames[_wheel(item)] == 0

    def _enqueue(self, item: SpoolItem) -> None:
        with self._lock:
            if isinstance(item, MissingItem):
                self._declared.add(_wheel(item))
            elif isinstance(item, FrameItem):
                self._wheel_frames[_wheel(item)] += 1
            self._passes[item.key].outstanding += 1
            self._queue.append(item)
            self._lock.notify_all()

    def _write_pass(self, key: str) -> None:
        state = self._passes[key]
        record = {"request": asdict(state.request), "pass_id": state.pass_id, "ended": state.ended}
        _write_json(self.folder / key / "pass.json", record)

    def _load_pass(self, pass_dir: Path) -> None:
        record = json.loads((pass_dir / "pass.json").read_text(encoding="utf-8"))
        key = pass_dir.name
        self._passes[key] = _Pass(PassOpen(**record["request"]), record["pass_id"], False, 0, False)
        for png in sorted(pass_dir.glob("f-*.png")):
            labels_path = png.with_suffix(".json")
            if not labels_path.is_file():
                png.unlink()
                continue
            labels = json.loads(labels_path.read_text(encoding="utf-8"))
            _, sensor, seq = png.stem.rsplit("-", 2)
            nbytes = png.stat().st_size
            self._used_bytes += nbytes
            vehicle_id, axle, sha256 = labels["vehicle_id"], labels["axle"], labels["sha256"]
            self._enqueue(FrameItem(key, sensor, int(seq), vehicle_id, axle, sha256, nbytes, png))
        for path in sorted(pass_dir.glob("m-*.json")):
            body = json.loads(path.read_text(encoding="utf-8"))
            self._missing_count = max(self._missing_count, int(path.stem[2:]))
            self._enqueue(MissingItem(key, path=path, **body))
        self._passes[key].ended = True


def _wheel(item: FrameItem | MissingItem) -> tuple[str, str, int, str]:
    side = item.side if isinstance(item, MissingItem) else item.sensor.split("_")[0]
    return (item.key, item.vehicle_id, item.axle, side)


def _write_json(path: Path, data: object) -> None:
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(data), encoding="utf-8")
    os.replace(tmp, path)
