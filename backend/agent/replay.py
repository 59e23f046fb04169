"""A station of emulated cameras replaying a recorded (or simulated) pass archive.

For tests and demos: from a `wheelscan-pass/1` archive, write per sensor a folder of its
frames in trigger order (the emulated camera replays a folder in file-name order), the
wheel-sensor events (one "axle" per axle of the manifest, in manifest order, then "end"),
the tag-reader records (one per vehicle, with its axle count) and a station file whose
cameras are pylon's emulated ones (serials 0815-0000 … in sensor order, software-triggered).
Run the agent on it with ``PYLON_CAMEMU=4``.
"""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path

from backend.agent.station import SENSORS
from pipeline.archive.manifest import PassManifest, WheelEntry
from pipeline.archive.pass_archive import read_pass_archive

EMULATED_SERIALS = tuple(f"0815-{n:04d}" for n in range(len(SENSORS)))
"""Serial numbers pylon gives its emulated cameras, in enumeration order."""


def axle_order(manifest: PassManifest) -> list[tuple[str, int]]:
    """(vehicle_id, axle) in the order the manifest first lists them (the trigger order)."""
    order: dict[tuple[str, int], None] = {}
    for wheel in manifest.wheels:
        order.setdefault((wheel.vehicle_id, wheel.axle), None)
    return list(order)


def write_replay_station(
    archive_path: str | Path,
    out_dir: str | Path,
    *,
    spool_limit_mb: float = 512.0,
    timeout_s: float = 2.0,
) -> Path:
    """Write replay folders, event files and a station file; returns the station file.

    Raises
    ------
    ValueError
        The archive is invalid, or its sensors took different numbers of frames per wheel
        (a replay needs one `frames_per_wheel`).
    """
    archive = read_pass_archive(archive_path, decode_frames=False)
    manifest = archive.manifest
    out = Path(out_dir)
    wheels = {(w.vehicle_id, w.axle, w.side): w for w in manifest.wheels}
    axles = axle_order(manifest)
    frames_per_wheel = _frames_per_wheel(manifest.wheels)
    sensors: dict[str, object] = {}
    depth = 8
    for serial, sensor in zip(EMULATED_SERIALS, SENSORS, strict=True):
        side, position = sensor.split("_")
        folder = out / "replay" / sensor
        folder.mkdir(parents=True, exist_ok=True)
        n = 0
        for vehicle_id, axle in axles:
            wheel = wheels.get((vehicle_id, axle, side))
            for path in () if wheel is None else wheel.frames(position):
                data = archive.frame_bytes(path)
                depth = max(depth, 16 if data[24] == 16 else 8)
                (folder / f"{n:06d}.png").write_bytes(data)
                n += 1
        sensors[sensor] = {
            "camera": serial,
            "trigger_source": "Software",
            "timeout_s": timeout_s,
            "replay_dir": str(folder.resolve()),
        }
    width, height = _image_size(archive.frame_bytes(manifest.wheels[0].frames("inner")[0]))
    for config in sensors.values():
        config["pixel_format"] = "Mono16" if depth == 16 else "Mono8"  # type: ignore[index]
    _write_lines(out / "axles.jsonl", _axle_events(manifest, len(axles)))
    counts = Counter(vehicle_id for vehicle_id, _ in axles)
    tags = [{"vehicle_id": v, "axles": counts[v]} for v in dict.fromkeys(v for v, _ in axles)]
    _write_lines(out / "tags.jsonl", tags)
    station = {
        "site": manifest.site,
        "direction": manifest.direction,
        "frames_per_wheel": frames_per_wheel,
        "image_width_px": width,
        "image_height_px": height,
        "spool_dir": str((out / "spool").resolve()),
        "spool_limit_mb": spool_limit_mb,
        "wheel_sensor": {"source": f"file:{(out / 'axles.jsonl').resolve()}"},
        "tag_reader": {"source": f"file:{(out / 'tags.jsonl').resolve()}"},
        "sensors": sensors,
    }
    if archive.has_own_calibration:
        (out / "calibration.json").write_bytes(archive.frame_bytes("calibration.json"))
        station["calibration"] = "calibration.json"
    station_path = out / "station.json"
    station_path.write_text(json.dumps(station, indent=2), encoding="utf-8")
    return station_path


def _frames_per_wheel(wheels: tuple[WheelEntry, ...]) -> int:
    counts = {len(w.frames(p)) for w in wheels for p in ("inner", "outer")}
    sides = Counter((w.vehicle_id, w.axle) for w in wheels)
    if len(counts) != 1 or 0 in counts or set(sides.values()) != {2}:
        raise ValueError(
            "a replay needs both wheels of every axle with one frame count per sensor, "
            f"got frame counts {sorted(counts)}"
        )
    return counts.pop()


def _axle_events(manifest: PassManifest, axles: int) -> list[dict[str, object]]:
    events: list[dict[str, object]] = [
        {"event": "axle", "speed_kmh": manifest.speed_kmh} for _ in range(axles)
    ]
    return [*events, {"event": "end"}]


def _image_size(png: bytes) -> tuple[int, int]:
    return int.from_bytes(png[16:20], "big"), int.from_bytes(png[20:24], "big")


def _write_lines(path: Path, records: list[dict[str, object]]) -> None:
    path.write_text("".join(json.dumps(r) + "\n" for r in records), encoding="utf-8")
