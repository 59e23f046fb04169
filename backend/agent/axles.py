"""From the trigger sequence to wheel labels: axle counting and vehicle identities.

The wheel sensor (a rail contact in front of the measuring zone) reports one event per axle;
the same pulse triggers the cameras. An optional tag reader upstream of the zone reports one
record per vehicle. Both speak JSON lines:

wheel sensor ::

    {"event": "axle"}                      one axle entered the zone (optional "speed_kmh")
    {"event": "end"}                       the train has left (silence also ends a pass)

tag reader ::

    {"vehicle_id": "80-91-012", "axles": 4}   "axles" optional (default: the station's)

Axles are numbered 1, 2, ... within their vehicle; a vehicle without a tag record is numbered
by its position in the train ("1", "2", ...).
"""

from __future__ import annotations

import json
import math
import queue
import socket
import threading
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from urllib.parse import urlsplit

MAX_LINE_BYTES = 4096


class EventError(ValueError):
    """An event line is not valid JSON of the expected shape."""


@dataclass(frozen=True, slots=True)
class AxleEvent:
    """One axle entered the measuring zone."""

    speed_kmh: float | None = None


@dataclass(frozen=True, slots=True)
class EndEvent:
    """The train has left the station (or the event stream ended)."""


@dataclass(frozen=True, slots=True)
class VehicleTag:
    """A vehicle identity from the tag reader."""

    vehicle_id: str
    axles: int | None = None


@dataclass(frozen=True, slots=True)
class AxleLabel:
    """What the frames of one triggered axle are labelled with.

    Attributes
    ----------
    index : int
        0-based axle number within the pass (each sensor's frames of this axle have
        seq = index * frames_per_wheel + k).
    vehicle_id : str
    axle : int
        1-based axle number within the vehicle.
    """

    index: int
    vehicle_id: str
    axle: int


class AxleCounter:
    """Counts axles of one pass and assigns each to a vehicle.

    Parameters
    ----------
    axles_per_vehicle : int
        Axles of a vehicle that has no tag record (or a tag without "axles").
    """

    def __init__(self, axles_per_vehicle: int) -> None:
        if axles_per_vehicle < 1:
            raise ValueError(f"axles_per_vehicle must be ≥ 1, got {axles_per_vehicle}")
        self._axles_per_vehicle = axles_per_vehicle
        self._index = -1
        self._vehicles = 0
        self._vehicle_id = ""
        self._axle = 0
        self._vehicle_axles = 0

    def count_axle(self, take_tag: Callable[[], VehicleTag | None]) -> AxleLabel:
        """Label the next axle; `take_tag` is asked once per new vehicle for its identity."""
        self._index += 1
        if self._axle == self._vehicle_axles:
            self._vehicles += 1
            tag = take_tag()
            self._vehicle_id = str(self._vehicles) if tag is None else tag.vehicle_id
            axles = None if tag is None else tag.axles
            self._vehicle_axles = self._axles_per_vehicle if axles is None else axles
            self._axle = 0
        self._axle += 1
        return AxleLabel(self._index, self._vehicle_id, self._axle)


def parse_wheel_event(line: str) -> AxleEvent | EndEvent:
    """Parse one wheel-sensor line; raises EventError naming what is wrong."""
    data = _json_object(line, "wheel-sensor")
    kind = data.get("event")
    if kind == "end":
        return EndEvent()
    if kind != "axle":
        raise EventError(f"wheel-sensor event must be 'axle' or 'end', got {kind!r}")
    speed = data.get("speed_kmh")
    if speed is not None and (
        isinstance(speed, bool) or not isinstance(speed, int | float) or not math.isfinite(speed)
    ):
        raise EventError(f"wheel-sensor speed_kmh must be a number, got {speed!r}")
    return AxleEvent(None if speed is None else float(speed))


def parse_tag(line: str) -> VehicleTag:
    """Parse one tag-reader line; raises EventError naming what is wrong."""
    data = _json_object(line, "tag-reader")
    vehicle_id = data.get("vehicle_id")
    if not isinstance(vehicle_id, str) or not vehicle_id.strip() or len(vehicle_id) > 200:
        raise EventError(f"tag-reader vehicle_id must be a non-empty string, got {vehicle_id!r}")
    axles = data.get("axles")
    if axles is not None and (isinstance(axles, bool) or not isinstance(axles, int) or axles < 1):
        raise EventError(f"tag-reader axles must be an integer ≥ 1, got {axles!r}")
    return VehicleTag(vehicle_id, axles)


def _json_object(line: str, where: str) -> dict[str, object]:
    try:
        data = json.loads(line)
    except json.JSONDecodeError as exc:
        raise EventError(f"{where} line is not JSON ({exc.msg}): {line[:80]!r}") from None
    if not isinstance(data, dict):
        raise EventError(f"{where} line must be a JSON object, got {line[:80]!r}")
    return data


def iter_lines(source: str, stop: threading.Event) -> Iterator[str]:
    """Non-empty lines from a station event source ("file:/path" or "tcp://host:port").

    A file (or FIFO) ends at its end; a TCP source listens and reads each connection in turn
    until `stop` is set.
    """
    if source.startswith("file:"):
        with open(source[len("file:") :], encoding="utf-8") as stream:
            for line in stream:
                if line.strip():
                    yield line.strip()
        return
    parts = urlsplit(source)
    with socket.create_server((parts.hostname or "127.0.0.1", parts.port or 0)) as server:
        server.settimeout(0.2)
        while not stop.is_set():
            try:
                connection, _ = server.accept()
            except TimeoutError:
                continue
            with connection, connection.makefile("r", encoding="utf-8") as stream:
                for line in stream:
                    if line.strip():
                        yield line.strip()


def start_reader(
    source: str, parse: Callable[[str], object], out: queue.Queue[object], stop: threading.Event
) -> threading.Thread:
    """Read `source` in a daemon thread, putting on `out` each parsed event or the EventError
    of a bad line (reading goes on), the OSError that ended the source, then None."""

    def run() -> None:
        try:
            for line in iter_lines(source, stop):
                try:
                    out.put(parse(line))
                except EventError as exc:
                    out.put(exc)
        except OSError as exc:
            out.put(exc)
        out.put(None)

    thread = threading.Thread(target=run, name=f"events {source}", daemon=True)
    thread.start()
    return thread
