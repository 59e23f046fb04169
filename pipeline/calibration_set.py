"""Calibration image sets: reading them, calibrating a station, and simulating them.

A set is a target file (`target.json`, format `wheelscan-target/1`: the board and, per
sensor, the known pose T_track_board of the board on its track fixture) and frames named
`<sensor>/board-NN.png` (board under ambient light), `<sensor>/laser-NN.png` (laser line only,
same pose as board-NN) and `<sensor>/track.png` (the board on the fixture).
"""

from __future__ import annotations

import json
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from pipeline.calibration import SENSOR_NAMES, StationCalibration, write_calibration
from pipeline.camera_calibration import LaserView, calibrate_sensor
from pipeline.errors import CalibrationError
from pipeline.geometry import invert_rigid, rigid_transform
from pipeline.station import Station, build_station, look_at
from pipeline.target import Board, pixel_rays, render_board

TARGET_FORMAT = "wheelscan-target/1"
TARGET_NAME = "target.json"
_FRAME_NAME = re.compile(r"^(board|laser)-(\d+)\.png$|^track\.png$")


@dataclass(frozen=True, slots=True, eq=False)
class SensorFrames:
    """The frames of one sensor in a calibration set."""

    board_images: tuple[np.ndarray, ...]
    laser_views: tuple[LaserView, ...]
    track_image: np.ndarray
    T_track_board: np.ndarray


def read_target(path: str | Path) -> tuple[Board, dict[str, np.ndarray]]:
    """Read `target.json`: the board and the known T_track_board per sensor."""
    try:
        document = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise CalibrationError(f"cannot read target file {path}: {exc}") from None
    if not isinstance(document, dict) or document.get("format") != TARGET_FORMAT:
        raise CalibrationError(f"{path}: format must be {TARGET_FORMAT!r}")
    try:
        spec = document["board"]
        board = Board(int(spec["columns"]), int(spec["rows"]), float(spec["square_mm"]))
        poses = {n: np.array(m, dtype=float) for n, m in document["track_poses"].items()}
    except (KeyError, TypeError, ValueError) as exc:
        raise CalibrationError(f"{path}: malformed board or track_poses ({exc})") from None
    for name, pose in poses.items():
        if name not in SENSOR_NAMES or pose.shape != (4, 4):
            raise CalibrationError(f"{path}: track_poses.{name} must be a 4x4 pose of a sensor")
    return board, poses


def _read_frame(path: Path) -> np.ndarray:
    image = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if image is None or image.ndim != 2:
        raise CalibrationError(f"{path} is not a grey image")
    return image


def read_calibration_set(
    images: Sequence[str | Path], target: str | Path
) -> tuple[Board, dict[str, SensorFrames]]:
    """Group calibration frames by sensor (parent folder name) and role (file name).

    Parameters
    ----------
    images : sequence of str or Path
        Frame files, or folders whose `*.png` are taken.
    target : str or Path
        The set's target.json.

    Raises
    ------
    CalibrationError
        Unknown sensor folder or frame name, a laser frame without its board frame, a
        sensor without track frame or without a known fixture pose.
    """
    board, poses = read_target(target)
    files: list[Path] = []
    for item in map(Path, images):
        files.extend(sorted(item.rglob("*.png")) if item.is_dir() else [item])
    grouped: dict[str, dict[str, Path]] = {}
    for path in files:
        sensor = path.parent.name
        if sensor not in SENSOR_NAMES or not _FRAME_NAME.match(path.name):
            raise CalibrationError(
                f"{path}: frames must be <sensor>/board-NN.png, laser-NN.png or track.png"
            )
        grouped.setdefault(sensor, {})[path.stem] = path
    if not grouped:
        raise CalibrationError("no calibration frames given")
    return board, {
        name: _sensor_frames(name, named, poses) for name, named in sorted(grouped.items())
    }


def _sensor_frames(name: str, named: dict[str, Path], poses: dict[str, np.ndarray]) -> SensorFrames:
    if "track" not in named or name not in poses:
        raise CalibrationError(f"sensor {name}: needs track.png and its pose in the target file")
    views = []
    for stem in sorted(named):
        if stem.startswith("laser-"):
            partner = "board-" + stem.split("-", 1)[1]
            if partner not in named:
                raise CalibrationError(f"sensor {name}: {stem}.png has no {partner}.png")
            views.append(LaserView(_read_frame(named[partner]), _read_frame(named[stem])))
    lasered = {"board-" + s.split("-", 1)[1] for s in named if s.startswith("laser-")}
    boards = [
        _read_frame(named[s]) for s in sorted(named) if s.startswith("board-") and s not in lasered
    ]
    return SensorFrames(tuple(boards), tuple(views), _read_frame(named["track"]), poses[name])


def calibrate_station(
    board: Board,
    frames: dict[str, SensorFrames],
    *,
    progress: Callable[[int, int], None] | None = None,
) -> StationCalibration:
    """Calibrate every sensor of a set (see `pipeline.camera_calibration.calibrate_sensor`)."""
    sensors = []
    for index, name in enumerate(n for n in SENSOR_NAMES if n in frames):
        f = frames[name]
        sensors.append(
            calibrate_sensor(
                name, f.board_images, f.laser_views, f.track_image, f.T_track_board, board=board
            )
        )
        if progress is not None:
            progress(index + 1, len(frames))
    return StationCalibration(sensors=tuple(sensors))


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
