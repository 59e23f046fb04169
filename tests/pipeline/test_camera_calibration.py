"""Calibration from simulated target images, checked against the station's true calibration."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from pipeline.calibration.board import Board
from pipeline.calibration.camera import detect_board_corners, fit_plane
from pipeline.calibration.geometry import (
    apply_transform,
    invert_rigid,
    pixels_to_track_points,
    project_track_points,
)
from pipeline.calibration.image_sets import calibrate_station, read_calibration_set
from pipeline.calibration.model import read_calibration
from pipeline.errors import CalibrationError
from pipeline.profile.reference import load_reference_profile
from pipeline.simulation.calibration_images import write_synthetic_calibration_set
from pipeline.simulation.render import WheelPose, wheel_section
from pipeline.simulation.station import build_station
from pipeline.simulation.target_images import pixel_rays, render_board
from pipeline.simulation.wheel import wheel_profile

SENSOR = "right_outer"


@pytest.fixture(scope="module")
def calibration_set(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("calset")
    return write_synthetic_calibration_set(out, seed=2, sensors=(SENSOR,), intrinsic_views=5)


def test_plane_fit_by_hand() -> None:
    # Points on z = 100 + 0.5·x: normal ∝ (−0.5, 0, 1), d = 100/|n|.
    rng = np.random.default_rng(0)
    xy = rng.uniform(-50, 50, (200, 2))
    points = np.column_stack([xy, 100 + 0.5 * xy[:, 0]])
    plane, rms = fit_plane(points)
    norm = np.sqrt(1.25)
    np.testing.assert_allclose(plane.normal, [-0.5 / norm, 0, 1 / norm], atol=1e-12)
    assert plane.d_mm == pytest.approx(100 / norm) and rms < 1e-9


def test_collinear_laser_points_are_refused() -> None:
    t = np.linspace(0, 10, 50)
    with pytest.raises(CalibrationError, match="on one line"):
        fit_plane(np.column_stack([t, 2 * t, 3 * t]))


def test_corners_come_in_board_order_to_a_tenth_of_a_pixel() -> None:
    station = build_station()
    sensor = station.calibration.sensor("left_inner")
    board = Board()
    target = sensor.T_track_camera[:3, 3] + 480 * sensor.T_track_camera[:3, 2]
    rotation = sensor.T_track_camera[:3, :3] @ np.diag([-1.0, 1.0, -1.0])
    half = np.array([5.0, 3.5, 0.0]) * board.square_mm
    pose = np.eye(4)
    pose[:3, :3], pose[:3, 3] = rotation, target - rotation @ half
    image = render_board(
        sensor,
        board,
        invert_rigid(sensor.T_track_camera) @ pose,
        np.random.default_rng(1),
        laser=False,
        rays=pixel_rays(sensor),
    )
    corners = detect_board_corners(image, board)
    truth = project_track_points(apply_transform(pose, board.corners_mm), sensor)
    assert corners is not None
    assert np.abs(corners - truth).max() < 0.1
    assert detect_board_corners(np.zeros_like(image), board) is None


@pytest.mark.slow
def test_calibration_recovers_the_true_station(calibration_set: Path) -> None:
    board, frames = read_calibration_set(
        [calibration_set / SENSOR], calibration_set / "target.json"
    )
    fitted = calibrate_station(board, frames).sensor(SENSOR)
    true = read_calibration(calibration_set / "true-calibration.json").sensor(SENSOR)
    assert fitted.reprojection_rms_px < 0.1
    assert fitted.plane_rms_mm < 0.05
    station = build_station()
    profile = wheel_profile(load_reference_profile("LMA"))
    pose = WheelPose((0.0, 0.0, 410.0), (1.0, 0.0, 0.0), 1, 676.5, 410.0)
    samples = wheel_section(
        profile,
        pose,
        true,
        station.laser_origin(SENSOR),
        scatter_mm=np.full(profile.x_mm.size, 0.5),
    )
    x, y = samples.pixels[:, 0], samples.pixels[:, 1]
    error = pixels_to_track_points(x, y, fitted) - pixels_to_track_points(x, y, true)
    assert np.abs(error[:, [0, 2]]).max() < 0.05
    assert np.linalg.norm(error, axis=1).max() < 0.1


def test_set_with_unknown_sensor_folder(calibration_set: Path, tmp_path: Path) -> None:
    stray = tmp_path / "middle" / "board-01.png"
    stray.parent.mkdir()
    stray.write_bytes((calibration_set / SENSOR / "board-01.png").read_bytes())
    with pytest.raises(CalibrationError, match="frames must be <sensor>/board-NN.png"):
        read_calibration_set([stray], calibration_set / "target.json")


def test_laser_frame_without_its_board_frame(calibration_set: Path, tmp_path: Path) -> None:
    folder = tmp_path / SENSOR
    folder.mkdir()
    for name in ("laser-07.png", "track.png"):
        (folder / name).write_bytes((calibration_set / SENSOR / name).read_bytes())
    with pytest.raises(CalibrationError, match="laser-07.png has no board-07.png"):
        read_calibration_set([folder], calibration_set / "target.json")


def test_sensor_without_track_frame(calibration_set: Path, tmp_path: Path) -> None:
    folder = tmp_path / SENSOR
    folder.mkdir()
    (folder / "board-01.png").write_bytes((calibration_set / SENSOR / "board-01.png").read_bytes())
    with pytest.raises(CalibrationError, match="needs track.png"):
        read_calibration_set([folder], calibration_set / "target.json")


def test_malformed_target_file(tmp_path: Path) -> None:
    (tmp_path / "target.json").write_text(json.dumps({"format": "wheelscan-target/1"}))
    with pytest.raises(CalibrationError, match="malformed board or track_poses"):
        read_calibration_set([], tmp_path / "target.json")


def test_frame_that_is_not_an_image(calibration_set: Path, tmp_path: Path) -> None:
    folder = tmp_path / SENSOR
    folder.mkdir()
    (folder / "track.png").write_text("nope")
    with pytest.raises(CalibrationError, match="is not a grey image"):
        read_calibration_set([folder], calibration_set / "target.json")


def test_board_not_found_in_the_track_frame(calibration_set: Path, tmp_path: Path) -> None:
    folder = tmp_path / SENSOR
    folder.mkdir()
    for name in sorted(p.name for p in (calibration_set / SENSOR).glob("*.png")):
        (folder / name).write_bytes((calibration_set / SENSOR / name).read_bytes())
    cv2.imwrite(str(folder / "track.png"), np.zeros((1200, 1600), np.uint8))
    board, frames = read_calibration_set([folder], calibration_set / "target.json")
    with pytest.raises(CalibrationError, match="board was not found"):
        calibrate_station(board, frames)
