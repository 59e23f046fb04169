"""What the agent shows in the terminal: frames per sensor, wheels sent, buffer state.

Counters are updated from the camera and upload threads; `status()` renders one line and
`warn()` hands a line to the sink (the CLI's tqdm.write, on stderr). The buffer warning is
given once when the spool passes `WARN_FRACTION` of its limit and again when it is full, and
again only after the spool has fallen below `WARN_FRACTION`.
"""

from __future__ import annotations

import threading
from collections import Counter
from collections.abc import Callable

from backend.agent.client import PutResult
from backend.agent.spool import CloseItem, FrameItem, Spool, SpoolItem

WARN_FRACTION = 0.8
_SHORT = {"left_inner": "LI", "left_outer": "LO", "right_inner": "RI", "right_outer": "RO"}
MIB = 1024 * 1024


class Progress:
    """Thread-safe counters of one agent run.

    Parameters
    ----------
    sensors : sequence of str
        Sensors of the station.
    frames_per_wheel : int
    spool : Spool
    sink : callable
        Receives each warning line.
    """

    def __init__(
        self,
        sensors: tuple[str, ...],
        frames_per_wheel: int,
        spool: Spool,
        sink: Callable[[str], None],
    ) -> None:
        self._sensors = sensors
        self._frames_per_wheel = frames_per_wheel
        self._spool = spool
        self._sink = sink
        self._lock = threading.Lock()
        self.captured: Counter[str] = Counter()
        self.missing: Counter[str] = Counter()
        self.frames_sent = 0
        self.wheels_sent = 0
        self.passes_closed = 0
        self.online = True
        self._resolved: dict[tuple[str, str, int, str], set[str]] = {}
        self._frames_acked: Counter[tuple[str, str, int, str]] = Counter()
        self._buffer_level = 0

    def frame_captured(self, sensor: str) -> None:
        """A camera delivered a frame and it is spooled."""
        with self._lock:
            self.captured[sensor] += 1
        self._check_buffer()

    def frame_missing(self, sensor: str) -> None:
        """A sensor's frames of a wheel were declared missing."""
        with self._lock:
            self.missing[sensor] += 1

    def frame_refused(self, sensor: str) -> None:
        """The buffer had no room for a frame (it is declared missing)."""
        self.frame_missing(sensor)
        self._check_buffer(full=True)

    def opened(self, key: str, pass_id: int) -> None:
        """The server opened a spooled pass."""
        self._sink(f"pass {key} is server pass {pass_id}")

    def acknowledged(self, item: SpoolItem, result: PutResult | None) -> None:
        """The server acknowledged an item (`result` for frames)."""
        with self._lock:
            if isinstance(item, CloseItem):
                self.passes_closed += 1
                return
            wheel = (item.key, item.vehicle_id, item.axle, item.sensor.split("_")[0])
            if isinstance(item, FrameItem):
                self.frames_sent += result is not None
                self._frames_acked[(*wheel[:3], item.sensor)] += 1
                if self._frames_acked[(*wheel[:3], item.sensor)] < self._frames_per_wheel:
                    return
            self._resolve(wheel, item.sensor)

    def _resolve(self, wheel: tuple[str, str, int, str], sensor: str) -> None:
        resolved = self._resolved.setdefault(wheel, set())
        resolved.add(sensor)
        side_sensors = {s for s in self._sensors if s.startswith(wheel[3])}
        if resolved >= side_sensors and len(resolved) == len(side_sensors):
            self.wheels_sent += 1

    def set_offline(self, message: str) -> None:
        """The server went away; says so once per outage."""
        with self._lock:
            was_online, self.online = self.online, False
        if was_online:
            self._sink(f"server unavailable, buffering frames on disk: {message}")

    def set_online(self) -> None:
        """The server answers again; says so once."""
        with self._lock:
            was_online, self.online = self.online, True
        if not was_online:
            self._sink("server back, sending buffered frames")

    def warn(self, message: str) -> None:
        """Show one warning line."""
        self._sink(f"warning: {message}")

    def status(self) -> str:
        """One line: frames per sensor, wheels sent, buffer state, connection."""
        with self._lock:
            frames = " ".join(
                f"{_SHORT.get(s, s)} {self.captured[s]}"
                + (f"(-{self.missing[s]})" if self.missing[s] else "")
                for s in self._sensors
            )
            wheels, online = self.wheels_sent, self.online
        used = self._spool.used_bytes
        limit = self._spool.limit_bytes
        buffer = f"buffer {self._spool.waiting()} ({used / MIB:.1f}/{limit / MIB:.0f} MB)"
        return f"{frames} | wheels sent {wheels} | {buffer} | {'online' if online else 'OFFLINE'}"

    def _check_buffer(self, *, full: bool = False) -> None:
        fill = self._spool.used_bytes / self._spool.limit_bytes
        level = 2 if full else 1 if fill >= WARN_FRACTION else 0
        with self._lock:
            rising = level > self._buffer_level
            if rising or level == 0:  # lowered only below WARN_FRACTION: a frame that still
                self._buffer_level = level  # fits after a refusal does not re-arm "full"
        if rising:
            state = "full: new frames are declared missing" if level == 2 else "nearly full"
            self.warn(
                f"local buffer {state} ({fill:.0%} of {self._spool.limit_bytes / MIB:.0f} MB)"
            )
