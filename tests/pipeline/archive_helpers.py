"""Small valid calibrations, manifests and frames for the archive and calibration tests."""

from __future__ import annotations

import struct
import zlib
from dataclasses import fields
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from pipeline.archive.manifest import PassManifest, WheelEntry
from pipeline.archive.pass_archive import write_pass_archive
from pipeline.calibration.model import (
    SENSOR_NAMES,
    LaserPlane,
    SensorCalibration,
    StationCalibration,
)

WIDTH_PX, HEIGHT_PX = 40, 30


def small_calibration(bit_depth: int = 8) -> StationCalibration:
    """A valid four-sensor calibration for 40x30 px frames."""
    sensors = tuple(
        SensorCalibration(
            name=name,
            image_width_px=WIDTH_PX,
            image_height_px=HEIGHT_PX,
            bit_depth=bit_depth,
            camera_matrix=np.array([[100.0, 0, 20], [0, 100.0, 15], [0, 0, 1]]),
            dist_coeffs=np.array([-0.1, 0.01, 0.0, 0.0, 0.0]),
            laser_plane=LaserPlane(normal=np.array([0.0, 0.6, 0.8]), d_mm=500.0),
            T_track_camera=np.eye(4),
            reprojection_rms_px=0.05,
            plane_rms_mm=0.02,
        )
        for name in SENSOR_NAMES
    )
    return StationCalibration(sensors=sensors)


def small_manifest() -> PassManifest:
    """One axle: both wheels, one frame per sensor."""
    wheels = tuple(
        WheelEntry(
            vehicle_id="V1",
            axle=1,
            side=side,
            frames_inner=(f"frames/{side}_inner/000001.png",),
            frames_outer=(f"frames/{side}_outer/000001.png",),
        )
        for side in ("left", "right")
    )
    return PassManifest(
        site="test-site",
        started_at=datetime(2026, 11, 23, 12, 0, tzinfo=UTC),
        direction="up",
        speed_kmh=5.0,
        vehicles=("V1",),
        wheels=wheels,
    )


def small_frames(manifest: PassManifest, dtype: type = np.uint8) -> dict[str, np.ndarray]:
    """A frame with a horizontal bright line for every path the manifest lists."""
    frame = np.zeros((HEIGHT_PX, WIDTH_PX), dtype)
    frame[15, :] = 200
    return {p: frame for w in manifest.wheels for p in w.frames_inner + w.frames_outer}


def padded_png(data: bytes, padding_bytes: int, noise: bytes = b"") -> bytes:
    """`data` (a PNG) with a private chunk of `padding_bytes` (`noise`, then zeros) before
    its IEND."""
    iend = data.rindex(b"IEND") - 4
    body = noise + bytes(padding_bytes - len(noise))
    crc = zlib.crc32(b"zzPd" + body)
    padding = struct.pack(">I", padding_bytes) + b"zzPd" + body + struct.pack(">I", crc)
    return data[:iend] + padding + data[iend:]


def many_frames_zip(out: Path, frames_per_sensor: int) -> Path:
    """A valid zip of one axle whose four sensors have `frames_per_sensor` frames each."""
    manifest = small_manifest()
    wheels = tuple(
        WheelEntry(
            vehicle_id="V1",
            axle=1,
            side=side,
            frames_inner=tuple(f"{side}_inner/{i}.png" for i in range(frames_per_sensor)),
            frames_outer=tuple(f"{side}_outer/{i}.png" for i in range(frames_per_sensor)),
        )
        for side in ("left", "right")
    )
    many = PassManifest(
        **{f.name: getattr(manifest, f.name) for f in fields(manifest) if f.name != "wheels"},
        wheels=wheels,
    )
    return write_pass_archive(out, many, small_frames(many), calibration=small_calibration())
