"""The manifest of a `wheelscan-pass/1` archive: dataclasses, strict parsing and the JSON form.

The format: docs/formats.md, "Pass archive".
"""

from __future__ import annotations

import math
import posixpath
import re
from dataclasses import dataclass
from datetime import UTC, datetime

from pipeline.errors import ArchiveError

PASS_FORMAT = "wheelscan-pass/1"
SIDES = ("left", "right")
POSITIONS = ("inner", "outer")
"""Sensor positions of a wheel; the sensor name is `<side>_<position>`."""
MAX_NAME_CHARS = 100
"""Characters of a site name or vehicle id (the service stores at most this many)."""
MAX_DIRECTION_CHARS = 40
"""Characters of a pass's direction (the service stores at most this many)."""
_DRIVE = re.compile(r"^[A-Za-z]:")


@dataclass(frozen=True, slots=True, eq=False)
class WheelEntry:
    """One wheel of a pass and the frames each of its sensors took of it.

    Attributes
    ----------
    vehicle_id : str
        Vehicle identifier (one of the manifest's vehicles).
    axle : int
        Axle number within the vehicle, ≥ 1.
    side : str
        "left" or "right".
    frames_inner, frames_outer : tuple of str
        Archive-relative frame paths of the inner and outer sensor.
    """

    vehicle_id: str
    axle: int
    side: str
    frames_inner: tuple[str, ...]
    frames_outer: tuple[str, ...]

    def sensor_name(self, position: str) -> str:
        """Sensor that took this wheel's frames at `position` ("inner" or "outer")."""
        return f"{self.side}_{position}"

    def frames(self, position: str) -> tuple[str, ...]:
        """Frame paths of the sensor at `position`."""
        return self.frames_inner if position == "inner" else self.frames_outer


@dataclass(frozen=True, slots=True, eq=False)
class PassManifest:
    """What `manifest.json` says about a pass.

    Attributes
    ----------
    site : str
    started_at : datetime
        Timezone-aware start of the pass.
    direction : str
    speed_kmh : float
    vehicles : tuple of str
        Vehicle identifiers in train order.
    wheels : tuple of WheelEntry
    odometer_km : tuple of (str, float) pairs
        Odometer readings [km] of the vehicles that reported one at this pass (from the
        train's data or the fleet's records), in `vehicles` order; empty when none did.
    """

    site: str
    started_at: datetime
    direction: str
    speed_kmh: float
    vehicles: tuple[str, ...]
    wheels: tuple[WheelEntry, ...]
    odometer_km: tuple[tuple[str, float], ...] = ()

    def odometer_of(self, vehicle_id: str) -> float | None:
        """The odometer reading of a vehicle at this pass [km], None when it gave none."""
        return dict(self.odometer_km).get(vehicle_id)


def _text(value: object, where: str, max_chars: int = MAX_NAME_CHARS) -> str:
    if not isinstance(value, str) or not value.strip() or len(value) > max_chars:
        raise ArchiveError(
            f"manifest {where} must be a non-empty string of ≤ {max_chars} characters, "
            f"got {value!r}"
        )
    if "\x00" in value:
        raise ArchiveError(f"manifest {where} must not contain NUL characters, got {value!r}")
    return value


def check_member_path(path: object, where: str) -> str:
    """Return `path` when it is a safe archive-relative POSIX path, else raise ArchiveError."""
    if not isinstance(path, str) or not path:
        raise ArchiveError(f"{where} must be a non-empty path string, got {path!r}")
    if "\\" in path or "\x00" in path or path.startswith("/") or _DRIVE.match(path):
        raise ArchiveError(f"{where} must be a relative POSIX path, got {path!r}")
    parts = path.split("/")
    if any(part in ("", ".", "..") for part in parts) or posixpath.normpath(path) != path:
        raise ArchiveError(f"{where} must not contain '..', '.' or empty parts, got {path!r}")
    return path


def _frames(value: object, where: str) -> tuple[tuple[str, ...], tuple[str, ...]]:
    if not isinstance(value, dict):
        raise ArchiveError(f"manifest {where} must be an object {{inner: [...], outer: [...]}}")
    unknown = sorted(set(value) - set(POSITIONS))
    if unknown:
        raise ArchiveError(
            f"manifest {where} has unknown sensor {unknown[0]!r}; sensors are inner, outer"
        )
    lists = []
    for position in POSITIONS:
        paths = value.get(position, [])
        if not isinstance(paths, list):
            raise ArchiveError(f"manifest {where}.{position} must be a list of paths")
        lists.append(
            tuple(
                check_member_path(p, f"manifest {where}.{position}[{i}]")
                for i, p in enumerate(paths)
            )
        )
    if not lists[0] and not lists[1]:
        raise ArchiveError(f"manifest {where} lists no frames")
    return lists[0], lists[1]


def _wheel(value: object, index: int, vehicles: tuple[str, ...]) -> WheelEntry:
    where = f"wheels[{index}]"
    if not isinstance(value, dict):
        raise ArchiveError(f"manifest {where} must be an object")
    for key in ("vehicle_id", "axle", "side", "frames"):
        if key not in value:
            raise ArchiveError(f"manifest {where} lacks {key!r}")
    vehicle_id = _text(value["vehicle_id"], f"{where}.vehicle_id")
    if vehicle_id not in vehicles:
        raise ArchiveError(f"manifest {where}.vehicle_id {vehicle_id!r} is not in 'vehicles'")
    axle = value["axle"]
    if isinstance(axle, bool) or not isinstance(axle, int) or not 1 <= axle <= 64:
        raise ArchiveError(f"manifest {where}.axle must be an integer 1..64, got {axle!r}")
    side = value["side"]
    if side not in SIDES:
        raise ArchiveError(f"manifest {where}.side must be 'left' or 'right', got {side!r}")
    inner, outer = _frames(value["frames"], f"{where}.frames")
    return WheelEntry(vehicle_id, axle, side, inner, outer)


def _started_at(value: object) -> datetime:
    if not isinstance(value, str):
        raise ArchiveError(f"manifest started_at must be an ISO 8601 string, got {value!r}")
    try:
        started = datetime.fromisoformat(value)
    except ValueError:
        raise ArchiveError(f"manifest started_at is not ISO 8601: {value!r}") from None
    if started.tzinfo is None:
        raise ArchiveError(f"manifest started_at must carry a time zone (e.g. 'Z'), got {value!r}")
    try:
        return started.astimezone(UTC)
    except OverflowError:
        raise ArchiveError(f"manifest started_at is out of range in UTC: {value!r}") from None


def _vehicles(value: object) -> tuple[str, ...]:
    if not isinstance(value, list) or not value:
        raise ArchiveError("manifest vehicles must be a non-empty list of vehicle ids")
    vehicles = tuple(_text(v, f"vehicles[{i}]") for i, v in enumerate(value))
    if len(set(vehicles)) != len(vehicles):
        raise ArchiveError("manifest vehicles lists a vehicle id twice")
    return vehicles


MAX_ODOMETER_KM = 1e8
"""Largest odometer reading accepted [km] (a vehicle's whole life is some 10⁷ km)."""


def _odometer(value: object, vehicles: tuple[str, ...]) -> tuple[tuple[str, float], ...]:
    if not isinstance(value, dict):
        raise ArchiveError("manifest odometer_km must be an object {vehicle_id: km}")
    for vehicle_id, km in value.items():
        if vehicle_id not in vehicles:
            raise ArchiveError(f"manifest odometer_km names {vehicle_id!r}, not in 'vehicles'")
        if isinstance(km, bool) or not isinstance(km, int | float) or not math.isfinite(km):
            raise ArchiveError(f"manifest odometer_km[{vehicle_id!r}] must be a number, got {km!r}")
        if not 0 <= km <= MAX_ODOMETER_KM:
            raise ArchiveError(
                f"manifest odometer_km[{vehicle_id!r}] must be in [0, {MAX_ODOMETER_KM:.0e}] km, "
                f"got {km}"
            )
    return tuple((v, float(value[v])) for v in vehicles if v in value)


def parse_manifest(document: object) -> PassManifest:
    """Validate a parsed `manifest.json` document.

    Raises
    ------
    ArchiveError
        With one message naming the first fault (missing key, wrong type, unknown side or
        sensor, unsafe frame path, a wheel or frame listed twice).
    """
    if not isinstance(document, dict):
        raise ArchiveError("manifest must be a JSON object")
    fmt = document.get("format", PASS_FORMAT)
    if fmt != PASS_FORMAT:
        raise ArchiveError(f"manifest format must be {PASS_FORMAT!r}, got {fmt!r}")
    for key in ("site", "started_at", "direction", "speed_kmh", "vehicles", "wheels"):
        if key not in document:
            raise ArchiveError(f"manifest lacks {key!r}")
    speed = document["speed_kmh"]
    if isinstance(speed, bool) or not isinstance(speed, int | float) or not math.isfinite(speed):
        raise ArchiveError(f"manifest speed_kmh must be a number, got {speed!r}")
    if not 0 < speed <= 400:
        raise ArchiveError(f"manifest speed_kmh must be in (0, 400], got {speed}")
    vehicles = _vehicles(document["vehicles"])
    wheels_doc = document["wheels"]
    if not isinstance(wheels_doc, list) or not wheels_doc:
        raise ArchiveError("manifest wheels must be a non-empty list")
    wheels = tuple(_wheel(w, i, vehicles) for i, w in enumerate(wheels_doc))
    seen_wheels: set[tuple[str, int, str]] = set()
    seen_frames: set[str] = set()
    for wheel in wheels:
        identity = (wheel.vehicle_id, wheel.axle, wheel.side)
        if identity in seen_wheels:
            raise ArchiveError(
                f"manifest lists wheel vehicle {identity[0]!r} axle {identity[1]} "
                f"{identity[2]} twice"
            )
        seen_wheels.add(identity)
        for path in wheel.frames_inner + wheel.frames_outer:
            if path in seen_frames:
                raise ArchiveError(f"manifest lists frame {path!r} twice")
            seen_frames.add(path)
    return PassManifest(
        site=_text(document["site"], "site"),
        started_at=_started_at(document["started_at"]),
        direction=_text(document["direction"], "direction", MAX_DIRECTION_CHARS),
        speed_kmh=float(speed),
        vehicles=vehicles,
        wheels=wheels,
        odometer_km=_odometer(document.get("odometer_km", {}), vehicles),
    )


def manifest_to_document(manifest: PassManifest) -> dict:
    """The JSON document (plain dicts and lists) of a manifest."""
    return {
        "format": PASS_FORMAT,
        "site": manifest.site,
        "started_at": manifest.started_at.isoformat().replace("+00:00", "Z"),
        "direction": manifest.direction,
        "speed_kmh": manifest.speed_kmh,
        "vehicles": list(manifest.vehicles),
        "wheels": [
            {
                "vehicle_id": w.vehicle_id,
                "axle": w.axle,
                "side": w.side,
                "frames": {"inner": list(w.frames_inner), "outer": list(w.frames_outer)},
            }
            for w in manifest.wheels
        ],
    } | ({"odometer_km": dict(manifest.odometer_km)} if manifest.odometer_km else {})
