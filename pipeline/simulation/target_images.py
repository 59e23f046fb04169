"""Simulated images of checkerboard calibration targets (board model in
pipeline/calibration/board.py), with and without the laser line."""

from __future__ import annotations

import cv2
import numpy as np

from pipeline.calibration.board import Board
from pipeline.calibration.geometry import (
    apply_transform,
    invert_rigid,
    laser_plane_track,
    project_track_points,
)
from pipeline.calibration.model import SensorCalibration
from pipeline.simulation.frame_render import draw_stripe, expose
from pipeline.simulation.render import StripeSamples

BLACK_ALBEDO = 0.12
WHITE_ALBEDO = 0.85
AMBIENT_DN = 200.0
"""Grey level of a white square under the calibration lighting (8-bit scale)."""
LASER_PEAK_DN = 230.0
MARGIN_SQUARES = 0.8
"""White border around the pattern (in squares): corner detectors need a quiet zone."""
BACKGROUND_ALBEDO = 0.05
LASER_WIDTH_PX = 6.0


def pixel_rays(sensor: SensorCalibration) -> np.ndarray:
    """Undistorted camera rays (x', y', 1) of every pixel centre, shape (M·N, 3)."""
    rows, cols = np.mgrid[0 : sensor.image_height_px, 0 : sensor.image_width_px]
    pixels = np.column_stack([cols.ravel(), rows.ravel()]).astype(np.float64).reshape(-1, 1, 2)
    normalised = cv2.undistortPoints(pixels, sensor.camera_matrix, sensor.dist_coeffs)
    return np.column_stack([normalised.reshape(-1, 2), np.ones(pixels.shape[0])])


def _board_hits(rays: np.ndarray, T_camera_board: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Board-frame (u, v) where each ray meets the board plane, and the ray length to it."""
    normal = T_camera_board[:3, 2]
    origin = T_camera_board[:3, 3]
    scale = (normal @ origin) / (rays @ normal)
    hits = apply_transform(invert_rigid(T_camera_board), rays * scale[:, None])
    return hits[:, :2], scale


def _checker(uv: np.ndarray, board: Board, footprint_mm: np.ndarray) -> np.ndarray:
    """Albedo with area-averaged edges: each edge ramps over one pixel footprint."""
    u, v = uv[:, 0] / board.square_mm, uv[:, 1] / board.square_mm
    ramp = footprint_mm / board.square_mm

    def edge(t: np.ndarray, squares: int) -> np.ndarray:
        # Clipped to the pattern's outer square centres: no edge at the pattern's border.
        t = np.clip(t, -0.5, squares - 1.5)
        distance = np.abs(t - np.round(t))
        sign = np.where(np.floor(t) % 2 == 0, 1.0, -1.0)
        return sign * np.clip(distance / ramp, 0.0, 1.0)

    product = edge(u, board.columns + 1) * edge(v, board.rows + 1)
    inside = (u > -1) & (u < board.columns) & (v > -1) & (v < board.rows)
    black_weight = np.where(inside, 0.5 + 0.5 * product, 0.0)
    albedo = BLACK_ALBEDO * black_weight + WHITE_ALBEDO * (1 - black_weight)
    m = MARGIN_SQUARES
    on_card = (u > -1 - m) & (u < board.columns + m) & (v > -1 - m) & (v < board.rows + m)
    return np.where(on_card, albedo, BACKGROUND_ALBEDO)


def render_board(
    sensor: SensorCalibration,
    board: Board,
    T_camera_board: np.ndarray,
    rng: np.random.Generator,
    *,
    laser: bool,
    rays: np.ndarray,
) -> np.ndarray:
    """A frame of the board at a pose: lit by ambient light, or dark with the laser line on it.

    Parameters
    ----------
    sensor : SensorCalibration
        True calibration of the camera (and of its laser plane).
    board : Board
    T_camera_board : ndarray of shape (4, 4)
        Board pose in the camera frame [mm].
    rng : numpy.random.Generator
        Sensor noise.
    laser : bool
        False: the checkerboard under ambient light. True: ambient off, the laser line
        drawn where the laser plane meets the board, its brightness following the albedo.
    rays : ndarray of shape (M·N, 3)
        `pixel_rays(sensor)`, computed once per camera.
    """
    uv, ranges = _board_hits(rays, T_camera_board)
    footprint = ranges * np.linalg.norm(rays, axis=1) / sensor.camera_matrix[0, 0]
    albedo = _checker(uv, board, footprint).reshape(sensor.image_height_px, -1)
    if not laser:
        return expose((AMBIENT_DN * albedo).astype(np.float32), sensor.bit_depth, rng)
    image = np.zeros(albedo.shape, np.float32)
    samples = _laser_line(sensor, board, T_camera_board)
    if samples.pixels.shape[0] > 1:
        col = np.clip(np.round(samples.pixels[:, 0]).astype(int), 0, albedo.shape[1] - 1)
        row = np.clip(np.round(samples.pixels[:, 1]).astype(int), 0, albedo.shape[0] - 1)
        draw_stripe(image, samples, LASER_PEAK_DN * albedo[row, col] / WHITE_ALBEDO)
    return expose(image, sensor.bit_depth, rng)


def _laser_line(
    sensor: SensorCalibration, board: Board, T_camera_board: np.ndarray
) -> StripeSamples:
    """Samples of the laser plane ∩ board plane inside the board, in the image."""
    T_track_board = sensor.T_track_camera @ T_camera_board
    normal_track, d_track = laser_plane_track(sensor)
    board_normal = T_track_board[:3, 2]
    board_origin = T_track_board[:3, 3]
    direction = np.cross(normal_track, board_normal)
    direction /= np.linalg.norm(direction)
    # A point on both planes: least-norm solution of the two plane equations.
    a = np.vstack([normal_track, board_normal])
    b = np.array([d_track, board_normal @ board_origin])
    start = np.linalg.lstsq(a, b, rcond=None)[0]
    reach = 2.0 * board.square_mm * (board.columns + board.rows)
    t = np.linspace(-reach, reach, 8000)
    points = start + t[:, None] * direction
    uv = apply_transform(invert_rigid(T_track_board), points)[:, :2]
    on_board = (
        (uv[:, 0] > -board.square_mm)
        & (uv[:, 0] < board.columns * board.square_mm)
        & (uv[:, 1] > -board.square_mm)
        & (uv[:, 1] < board.rows * board.square_mm)
    )
    points = points[on_board]
    pixels = project_track_points(points, sensor)
    count = len(points)
    return StripeSamples(
        pixels=pixels,
        width_px=np.full(count, LASER_WIDTH_PX),
        irradiance=np.ones(count),
        outline_index=np.full(count, -1, np.int64),
        run_id=np.ones(count, np.int64),
        points_track_mm=points,
    )
