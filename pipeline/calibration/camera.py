"""Sensor calibration from checkerboard images: intrinsics, laser plane, camera-to-track.

1. Intrinsics and distortion (k1, k2, p1, p2; k3 fixed at 0 for a 16 mm lens) from the
   board's corners in several poses (OpenCV `calibrateCamera`).
2. The laser plane: at some poses a second, dark frame shows only the laser line on the
   board. Its centres, undistorted to rays and intersected with the board plane (the pose
   from the ambient frame), are 3-D points of the light plane; a least-squares plane (SVD)
   through all of them is the laser plane.
3. Camera-to-track: the board mounted at a known pose in the track frame (a fixture on the
   rail): T_track_camera = T_track_board · T_camera_board⁻¹.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from pipeline.calibration.board import Board
from pipeline.calibration.geometry import (
    apply_transform,
    invert_rigid,
    rigid_transform,
    undistort_pixels,
)
from pipeline.calibration.model import LaserPlane, SensorCalibration
from pipeline.errors import CalibrationError
from pipeline.extraction.centres import extract_centres
from pipeline.imaging import GEOMETRY_FLOAT, validate_image

MIN_BOARD_VIEWS = 4
MIN_PLANE_POSES = 2
CALIBRATION_FLAGS = cv2.CALIB_FIX_K3
CORNER_FLAGS = cv2.CALIB_CB_EXHAUSTIVE


@dataclass(frozen=True, slots=True, eq=False)
class LaserView:
    """One laser pose: the board under ambient light and the laser-only frame at that pose."""

    board_image: np.ndarray
    laser_image: np.ndarray


def _to_8bit(image: np.ndarray) -> np.ndarray:
    image = validate_image(image)
    if image.dtype == np.uint16:
        return (image >> 8).astype(np.uint8)
    return image.astype(np.uint8)


def detect_board_corners(image: np.ndarray, board: Board) -> np.ndarray | None:
    """Sub-pixel inner corners in board order, shape (K, 2) [px]; None when not found.

    The detector's labelling of the grid is made physical: the board is seen from its printed
    face (its z axis towards the camera, so x × y turns counter-clockwise in the image),
    and the square diagonally outside corner 0 is black (see `pipeline.calibration.board`).
    """
    grey = _to_8bit(image)
    found, corners = cv2.findChessboardCornersSB(
        grey, (board.columns, board.rows), flags=CORNER_FLAGS
    )
    if not found:
        return None
    grid = corners.reshape(board.rows, board.columns, 2).astype(GEOMETRY_FLOAT)
    along, down = grid[0, 1] - grid[0, 0], grid[1, 0] - grid[0, 0]
    if along[0] * down[1] - along[1] * down[0] > 0:
        grid = grid[:, ::-1]
    c0, c1, below = grid[0, 0], grid[0, 1], grid[1, 0]
    outside = c0 - 0.5 * (c1 - c0) - 0.5 * (below - c0)
    beside = c0 + 0.5 * (c1 - c0) - 0.5 * (below - c0)
    if _grey_at(grey, outside) > _grey_at(grey, beside):
        grid = grid[::-1, ::-1]
    return np.ascontiguousarray(grid.reshape(-1, 2))


def _grey_at(grey: np.ndarray, point: np.ndarray) -> float:
    """Mean grey level of a 5×5 px patch centred on a sub-pixel point."""
    return float(cv2.getRectSubPix(grey, (5, 5), (float(point[0]), float(point[1]))).mean())


def _corners_or_raise(image: np.ndarray, board: Board, what: str) -> np.ndarray:
    corners = detect_board_corners(image, board)
    if corners is None:
        raise CalibrationError(f"{what}: the {board.columns}x{board.rows} board was not found")
    return corners


def board_pose(corners_px: np.ndarray, board: Board, camera_matrix, dist_coeffs) -> np.ndarray:
    """T_camera_board from detected corners (iterative PnP) [mm]."""
    ok, rvec, tvec = cv2.solvePnP(
        board.corners_mm, corners_px, camera_matrix, dist_coeffs, flags=cv2.SOLVEPNP_ITERATIVE
    )
    if not ok:
        raise CalibrationError("the board pose could not be solved")
    return rigid_transform(cv2.Rodrigues(rvec)[0], tvec.ravel())


def fit_plane(points_mm: np.ndarray) -> tuple[LaserPlane, float]:
    """Least-squares plane through points (SVD); returns the plane (d > 0) and RMS distance.

    Raises
    ------
    CalibrationError
        If the points are too few or lie on a line.
    """
    if points_mm.shape[0] < 10:
        raise CalibrationError(f"too few laser points for a plane fit ({points_mm.shape[0]})")
    centre = points_mm.mean(axis=0)
    _, singular, vt = np.linalg.svd(points_mm - centre, full_matrices=False)
    if singular[1] < 1e-6 * singular[0]:
        raise CalibrationError("the laser points lie on one line: use several board poses")
    normal = vt[2]
    d = float(normal @ centre)
    if d < 0:
        normal, d = -normal, -d
    rms = float(np.sqrt(np.mean((points_mm @ normal - d) ** 2)))
    return LaserPlane(normal=normal, d_mm=d), rms


def stripe_points_on_board(
    laser_image: np.ndarray,
    T_camera_board: np.ndarray,
    camera_matrix: np.ndarray,
    dist_coeffs: np.ndarray,
    *,
    board: Board,
    name: str,
) -> np.ndarray:
    """Laser-line centres of a frame intersected with the board plane (camera frame) [mm]."""
    centres = extract_centres(laser_image, method="steger", width_min=3, width_max=12)
    if len(centres) < 20:
        raise CalibrationError(f"{name}: a laser frame shows no laser line on the board")
    normalised = undistort_pixels(centres.x, centres.y, camera_matrix, dist_coeffs)
    rays = np.column_stack([normalised, np.ones(len(centres))])
    normal, origin = T_camera_board[:3, 2], T_camera_board[:3, 3]
    points = rays * ((normal @ origin) / (rays @ normal))[:, None]
    uv = apply_transform(invert_rigid(T_camera_board), points)[:, :2] / board.square_mm
    on_board = (uv[:, 0] > -1) & (uv[:, 0] < board.columns)
    on_board &= (uv[:, 1] > -1) & (uv[:, 1] < board.rows)
    return points[on_board]


def calibrate_sensor(
    name: str,
    board_images: Sequence[np.ndarray],
    laser_views: Sequence[LaserView],
    track_image: np.ndarray,
    T_track_board: np.ndarray,
    *,
    board: Board,
) -> SensorCalibration:
    """Calibrate one sensor from its board, laser and track-target frames.

    Parameters
    ----------
    name : str
        Sensor name.
    board_images : sequence of ndarray
        Board frames under ambient light at varied poses (intrinsics).
    laser_views : sequence of LaserView
        At least two poses with the laser line on the board.
    track_image : ndarray
        The board on its fixture at the known pose `T_track_board`.
    T_track_board : ndarray of shape (4, 4)
        Pose of the fixture's board in the track frame [mm].
    board : Board

    Returns
    -------
    SensorCalibration
        With the reprojection RMS [px] and the plane-fit RMS [mm].

    Raises
    ------
    CalibrationError
        Too few views, a board or laser line not found, a degenerate plane.
    """
    if len(laser_views) < MIN_PLANE_POSES:
        raise CalibrationError(
            f"{name}: need ≥ {MIN_PLANE_POSES} laser poses, got {len(laser_views)}"
        )
    # Boards for the intrinsics alone may be missed (skipped); laser and track boards may not.
    free = [c for c in (detect_board_corners(f, board) for f in board_images) if c is not None]
    fixed_frames = [*(v.board_image for v in laser_views), track_image]
    fixed = [
        _corners_or_raise(f, board, f"{name} laser/track frame {i}")
        for i, f in enumerate(fixed_frames)
    ]
    corners = free + fixed
    if len(corners) < MIN_BOARD_VIEWS:
        raise CalibrationError(
            f"{name}: the board was found in {len(corners)} frames, need ≥ {MIN_BOARD_VIEWS}"
        )
    height, width = track_image.shape
    objects = [board.corners_mm.astype(np.float32)] * len(corners)
    rms, camera_matrix, dist, _, _ = cv2.calibrateCamera(
        objects,
        [c.astype(np.float32) for c in corners],
        (width, height),
        None,
        None,
        flags=CALIBRATION_FLAGS,
        criteria=(cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 200, 1e-12),
    )
    dist = dist.ravel()[:5]
    points = []
    for k, view in enumerate(laser_views):
        pose = board_pose(fixed[k], board, camera_matrix, dist)
        points.append(
            stripe_points_on_board(
                view.laser_image, pose, camera_matrix, dist, board=board, name=name
            )
        )
    plane, plane_rms = fit_plane(np.concatenate(points))
    T_camera_board = board_pose(corners[-1], board, camera_matrix, dist)
    return SensorCalibration(
        name=name,
        image_width_px=width,
        image_height_px=height,
        bit_depth=8 if track_image.dtype == np.uint8 else 16,
        camera_matrix=camera_matrix,
        dist_coeffs=dist,
        laser_plane=plane,
        T_track_camera=np.asarray(T_track_board) @ invert_rigid(T_camera_board),
        reprojection_rms_px=float(rms),
        plane_rms_mm=plane_rms,
    )
