"""Calibration image sets: reading them and calibrating a station from them.

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

from pipeline.calibration.board import Board
from pipeline.calibration.camera import LaserView, calibrate_sensor
from pipeline.calibration.model import SENSOR_NAMES, StationCalibration
from pipeline.errors import CalibrationError

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
    """Calibrate every sensor of a set (see `pipeline.calibration.camera.calibrate_sensor`)."""
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
