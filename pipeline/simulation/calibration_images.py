"""Simulated calibration image sets of the simulated station, with their true calibration.

The set's format is that of pipeline/calibration/image_sets.py.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from pathlib import Path

import cv2
import numpy as np

from pipeline.calibration.board import Board
from pipeline.calibration.geometry import invert_rigid, rigid_transform
from pipeline.calibration.image_sets import TARGET_FORMAT, TARGET_NAME
from pipeline.calibration.model import SENSOR_NAMES, StationCalibration, write_calibration
from pipeline.simulation.station import Station, build_station, look_at
from pipeline.simulation.target_images import pixel_rays, render_board


def _rotation(rng: np.random.Generator, spread_rad: float) -> np.ndarray:
    rvec = rng.normal(0.0, spread_rad, 3)
    return cv2.Rodrigues(rvec)[0]


def _board_pose_at(
    centre_track: np.ndarray, camera_track: np.ndarray, board: Board, tilt: np.ndarray
) -> np.ndarray:
    """T_track_board with the board's centre at `centre`, facing the camera, tilted."""
    facing = look_at(camera_track, centre_track)
    # Board z points back at the camera: flip the camera's z (and x to stay right-handed).
    rotation = facing[:3, :3] @ np.diag([-1.0, 1.0, -1.0]) @ tilt
    half = np.array([(board.columns - 1) / 2, (board.rows - 1) / 2, 0.0]) * board.square_mm
    return rigid_transform(rotation, centre_track - rotation @ half)


def _sensor_poses(
    station: Station, name: str, board: Board, rng: np.random.Generator, intrinsic_views: int
):
    """(intrinsic poses, laser poses, track pose) as T_track_board for one sensor."""
    sensor = station.calibration.sensor(name)
    camera = sensor.T_track_camera[:3, 3]
    axis = sensor.T_track_camera[:3, 2]
    normal = sensor.T_track_camera[:3, :3] @ sensor.laser_plane.normal
    d = sensor.laser_plane.d_mm + normal @ camera
    on_plane = camera + axis * (d - normal @ camera) / (normal @ axis)
    range_mm = float(np.linalg.norm(on_plane - camera))
    right, down = sensor.T_track_camera[:3, 0], sensor.T_track_camera[:3, 1]
    intrinsic = []
    for i in range(intrinsic_views):
        ox, oy = (i % 3 - 1) * 0.05 * range_mm, (i // 3 - 1) * 0.04 * range_mm
        centre = camera + axis * range_mm * rng.uniform(0.9, 1.1) + right * ox + down * oy
        intrinsic.append(_board_pose_at(centre, camera, board, _rotation(rng, 0.3)))
    laser = []
    for i in range(3):
        shift = rng.normal(0, 12.0, 3)
        centre = on_plane + shift - normal * (normal @ shift)
        tilt = _rotation(rng, 0.25) if i else np.eye(3)
        laser.append(_board_pose_at(centre, camera, board, tilt))
    track = _board_pose_at(on_plane, camera, board, _rotation(rng, 0.15))
    return intrinsic, laser, track


def write_synthetic_calibration_set(
    out: str | Path,
    *,
    seed: int = 0,
    bit_depth: int = 8,
    sensors: Sequence[str] = SENSOR_NAMES,
    intrinsic_views: int = 9,
    progress: Callable[[int, int], None] | None = None,
) -> Path:
    """Render a calibration set of the simulated station, with its true calibration.

    Writes target.json, `<sensor>/board-NN.png`, `<sensor>/laser-NN.png`, `<sensor>/track.png`
    and true-calibration.json (what `calibrate` should recover) into `out`.

    Parameters
    ----------
    out : str or Path
    seed : int
        Board poses and sensor noise.
    bit_depth : int
        8 or 16.
    sensors : sequence of str
        Sensors to render for.
    intrinsic_views : int
        Board poses for the intrinsics, besides the 3 laser poses and the track pose.
    progress : callable(done, total), optional
        Called after each sensor.
    """
    unknown = sorted(set(sensors) - set(SENSOR_NAMES))
    if unknown:
        raise ValueError(f"sensors must be among {', '.join(SENSOR_NAMES)}, got {unknown[0]!r}")
    station = build_station(bit_depth=bit_depth)
    board = Board()
    rng = np.random.default_rng(seed)
    out = Path(out)
    poses = {}
    for name in sensors:
        sensor = station.calibration.sensor(name)
        rays = pixel_rays(sensor)
        intrinsic, laser, track = _sensor_poses(station, name, board, rng, intrinsic_views)
        folder = out / name
        folder.mkdir(parents=True, exist_ok=True)
        to_camera = invert_rigid(sensor.T_track_camera)
        for i, pose in enumerate(intrinsic + laser):
            T_camera_board = to_camera @ pose
            image = render_board(sensor, board, T_camera_board, rng, laser=False, rays=rays)
            cv2.imwrite(str(folder / f"board-{i + 1:02d}.png"), image)
            if i >= len(intrinsic):
                image = render_board(sensor, board, T_camera_board, rng, laser=True, rays=rays)
                cv2.imwrite(str(folder / f"laser-{i + 1:02d}.png"), image)
        image = render_board(sensor, board, to_camera @ track, rng, laser=False, rays=rays)
        cv2.imwrite(str(folder / "track.png"), image)
        poses[name] = track.tolist()
        if progress is not None:
            progress(len(poses), len(sensors))
    target = {
        "format": TARGET_FORMAT,
        "board": {"columns": board.columns, "rows": board.rows, "square_mm": board.square_mm},
        "track_poses": poses,
    }
    (out / TARGET_NAME).write_text(json.dumps(target, indent=2) + "\n", encoding="utf-8")
    true = StationCalibration(sensors=tuple(station.calibration.sensor(n) for n in sensors))
    write_calibration(true, out / "true-calibration.json")
    return out
