"""The station file: which camera is which sensor, how it is set up, where events come from.

A station file is JSON (``.json``) or TOML (``.toml``)::

    site = "ZW-01"
    server = "http://127.0.0.1:8000"      # optional; `--server` overrides it
    frames_per_wheel = 2
    axles_per_vehicle = 4                  # vehicles without a tag record
    image_width_px = 1600
    image_height_px = 1200
    direction = "up"                       # optional
    pass_end_gap_s = 10.0                  # silence that ends a pass
    spool_dir = "/var/spool/wheelscan"     # local buffer while the server is away
    spool_limit_mb = 2048
    calibration = "calibration.json"       # optional; else the site's registered one

    [wheel_sensor]                         # axle events, JSON lines
    source = "tcp://127.0.0.1:7001"        # or "file:/path" (a file or a FIFO)

    [tag_reader]                           # optional vehicle identities, JSON lines
    source = "file:/run/tags.fifo"

    [sensors.left_inner]
    camera = "21234567"                    # serial number or device user id
    exposure_us = 800.0
    pixel_format = "Mono8"                 # Mono8, Mono10, Mono12 or Mono16
    trigger_source = "Line1"               # "Software" for emulated cameras
    timeout_s = 0.5                        # per frame, after the axle event
    replay_dir = "frames/left_inner"       # optional: emulated camera replays this folder

Relative paths are relative to the station file. Every error names the key and what to fix.
"""

from __future__ import annotations

import json
import math
import tomllib
from dataclasses import dataclass
from pathlib import Path
from urllib.parse import urlsplit

SENSORS = ("left_inner", "left_outer", "right_inner", "right_outer")
PIXEL_FORMATS = ("Mono8", "Mono10", "Mono12", "Mono16")
TRIGGER_SOURCES = ("Software", "Line1", "Line2", "Line3", "Line4")
_TOP_KEYS = {
    "site",
    "server",
    "frames_per_wheel",
    "axles_per_vehicle",
    "image_width_px",
    "image_height_px",
    "direction",
    "pass_end_gap_s",
    "spool_dir",
    "spool_limit_mb",
    "calibration",
    "upload_workers",
    "wheel_sensor",
    "tag_reader",
    "sensors",
}
_SENSOR_KEYS = {
    "camera",
    "exposure_us",
    "pixel_format",
    "trigger_source",
    "timeout_s",
    "replay_dir",
}


class StationError(ValueError):
    """The station file is unreadable or invalid; the message names the key."""


@dataclass(frozen=True, slots=True)
class SensorConfig:
    """One camera of the station and the sensor it is."""

    sensor: str
    camera: str
    exposure_us: float
    pixel_format: str
    trigger_source: str
    timeout_s: float
    replay_dir: Path | None

    @property
    def side(self) -> str:
        """The wheel side this sensor looks at ("left" or "right")."""
        return self.sensor.split("_")[0]


@dataclass(frozen=True, slots=True)
class Station:
    """A validated station file."""

    path: Path
    site: str
    server: str | None
    frames_per_wheel: int
    axles_per_vehicle: int
    image_width_px: int
    image_height_px: int
    direction: str | None
    pass_end_gap_s: float
    spool_dir: Path
    spool_limit_mb: float
    calibration: Path | None
    upload_workers: int
    wheel_sensor_source: str
    tag_reader_source: str | None
    sensors: tuple[SensorConfig, ...]


def load_station(path: str | Path) -> Station:
    """Read and validate a station file (JSON or TOML).

    Raises
    ------
    StationError
        One line naming the file, the key and what is expected.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise StationError(f"station file {path}: cannot read ({exc.strerror})") from None
    try:
        if path.suffix.lower() == ".toml":
            data = tomllib.loads(text)
        elif path.suffix.lower() == ".json":
            data = json.loads(text)
        else:
            raise StationError(f"station file {path}: name must end in .json or .toml")
    except (tomllib.TOMLDecodeError, json.JSONDecodeError) as exc:
        first = str(exc).splitlines()[0]
        raise StationError(f"station file {path}: not valid {path.suffix[1:]}: {first}") from None
    try:
        return _station(data, path)
    except StationError as exc:
        raise StationError(f"station file {path}: {exc}") from None


def _station(data: object, path: Path) -> Station:
    if not isinstance(data, dict):
        raise StationError("the top level must be a table/object")
    _no_unknown(data, _TOP_KEYS, "")
    base = path.resolve().parent
    sensors_table = _required_table(data, "sensors")
    _no_unknown(sensors_table, set(SENSORS), "sensors.")
    if not sensors_table:
        raise StationError(f"sensors must list at least one of {', '.join(SENSORS)}")
    sensors = tuple(
        _sensor(name, sensors_table[name], base) for name in SENSORS if name in sensors_table
    )
    cameras = [s.camera for s in sensors]
    duplicate = next((c for c in cameras if cameras.count(c) > 1), None)
    if duplicate is not None:
        raise StationError(f"camera {duplicate!r} is given for more than one sensor")
    server = _text(data, "server")
    if server is not None:
        server = check_server_url(server)
    calibration = _text(data, "calibration")
    tag_reader = _table(data, "tag_reader")
    return Station(
        path=path,
        site=_required_text(data, "site"),
        server=server,
        frames_per_wheel=_int(data, "frames_per_wheel", 1, 1, 64),
        axles_per_vehicle=_int(data, "axles_per_vehicle", 4, 1, 64),
        image_width_px=_int(data, "image_width_px", 1600, 16, 16384),
        image_height_px=_int(data, "image_height_px", 1200, 16, 16384),
        direction=_text(data, "direction"),
        pass_end_gap_s=_number(data, "pass_end_gap_s", 10.0, 0.01, 3600.0),
        spool_dir=base / (_text(data, "spool_dir") or "wheelscan-spool"),
        spool_limit_mb=_number(data, "spool_limit_mb", 2048.0, 1.0, 1e7),
        calibration=None if calibration is None else base / calibration,
        upload_workers=_int(data, "upload_workers", 2, 1, 16),
        wheel_sensor_source=_source(_required_table(data, "wheel_sensor"), "wheel_sensor"),
        tag_reader_source=None if tag_reader is None else _source(tag_reader, "tag_reader"),
        sensors=sensors,
    )


def check_server_url(url: str) -> str:
    """Return `url` when it is an http(s) URL with a host, else raise StationError."""
    parts = urlsplit(url)
    if parts.scheme not in ("http", "https") or not parts.netloc:
        raise StationError(f"server must be an http:// or https:// URL, got {url!r}")
    return url.rstrip("/")


def _sensor(name: str, table: object, base: Path) -> SensorConfig:
    if not isinstance(table, dict):
        raise StationError(f"sensors.{name} must be a table/object")
    _no_unknown(table, _SENSOR_KEYS, f"sensors.{name}.")
    where = f"sensors.{name}."
    pixel_format = _choice(table, "pixel_format", PIXEL_FORMATS, "Mono8", where)
    trigger_source = _choice(table, "trigger_source", TRIGGER_SOURCES, "Line1", where)
    replay_dir = _text(table, "replay_dir", where)
    return SensorConfig(
        sensor=name,
        camera=_required_text(table, "camera", where),
        exposure_us=_number(table, "exposure_us", 1000.0, 1.0, 1e7, where),
        pixel_format=pixel_format,
        trigger_source=trigger_source,
        timeout_s=_number(table, "timeout_s", 0.5, 0.001, 600.0, where),
        replay_dir=None if replay_dir is None else base / replay_dir,
    )


def _source(table: dict[str, object], where: str) -> str:
    _no_unknown(table, {"source"}, f"{where}.")
    source = _required_text(table, "source", f"{where}.")
    if source.startswith("file:") and len(source) > len("file:"):
        return source
    if source.startswith("tcp://"):
        parts = urlsplit(source)
        if parts.hostname and parts.port:
            return source
    raise StationError(f"{where}.source must be 'file:/path' or 'tcp://host:port', got {source!r}")


def _no_unknown(table: dict[str, object], known: set[str], where: str) -> None:
    unknown = sorted(set(table) - known)
    if unknown:
        raise StationError(
            f"unknown key {where}{unknown[0]}; expected one of {', '.join(sorted(known))}"
        )


def _table(data: dict[str, object], key: str) -> dict[str, object] | None:
    value = data.get(key)
    if value is not None and not isinstance(value, dict):
        raise StationError(f"{key} must be a table/object, got {type(value).__name__}")
    return value


def _required_table(data: dict[str, object], key: str) -> dict[str, object]:
    value = _table(data, key)
    if value is None:
        raise StationError(f"missing [{key}] table")
    return value


def _text(data: dict[str, object], key: str, where: str = "") -> str | None:
    value = data.get(key)
    if value is not None and (not isinstance(value, str) or not value.strip()):
        raise StationError(f"{where}{key} must be a non-empty string, got {value!r}")
    return value


def _required_text(data: dict[str, object], key: str, where: str = "") -> str:
    value = _text(data, key, where)
    if value is None:
        raise StationError(f"missing {where}{key}")
    return value


def _choice(
    data: dict[str, object], key: str, choices: tuple[str, ...], default: str, where: str
) -> str:
    value = data.get(key, default)
    if value not in choices:
        raise StationError(f"{where}{key} must be one of {', '.join(choices)}, got {value!r}")
    return str(value)


def _int(data: dict[str, object], key: str, default: int, low: int, high: int) -> int:
    value = data.get(key, default)
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise StationError(f"{key} must be an integer {low}..{high}, got {value!r}")
    return value


def _number(
    data: dict[str, object],
    key: str,
    default: float,
    low: float,
    high: float,
    where: str = "",
) -> float:
    value = data.get(key, default)
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise StationError(f"{where}{key} must be a number, got {value!r}")
    if not math.isfinite(value) or not low <= value <= high:
        raise StationError(f"{where}{key} must be within {low:g}..{high:g}, got {value!r}")
    return float(value)
