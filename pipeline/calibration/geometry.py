"""Pixel ↔ millimetre geometry of one laser/camera sensor (docs/coordinate-frames.md).

A centre pixel goes: undistort → ray m (camera frame, z = 1) → light-plane intersection
P = (d / n·m) m → track frame T_track_camera · P. `project_track_points` is the inverse
(track frame → distorted pixel), used by the simulator and by round-trip checks.
"""

from __future__ import annotations

import cv2
import numpy as np

from pipeline.calibration.model import SensorCalibration
from pipeline.errors import PipelineError
from pipeline.imaging import GEOMETRY_FLOAT

UNDISTORT_CRITERIA = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-14)
"""Iterations of OpenCV's fixed-point undistortion: 100 steps to a 1e-14 change, so the
inversion error (≪ 1e-6 px) never shows in a measurement; OpenCV's default of 5 steps leaves
about 0.01 px at the corners of a 16 mm lens."""
MIN_RAY_PLANE_COSINE = 1e-3
"""Rays closer than this cosine to the light plane's own direction have no stable intersection."""


def rigid_transform(rotation: np.ndarray, translation_mm: np.ndarray) -> np.ndarray:
    """The 4×4 homogeneous transform [R t; 0 1] [mm]."""
    transform = np.eye(4, dtype=GEOMETRY_FLOAT)
    transform[:3, :3] = rotation
    transform[:3, 3] = translation_mm
    return transform


def invert_rigid(transform: np.ndarray) -> np.ndarray:
    """Inverse of a rigid 4×4 transform: T_b_a from T_a_b."""
    rotation = transform[:3, :3]
    return rigid_transform(rotation.T, -rotation.T @ transform[:3, 3])


def apply_transform(transform: np.ndarray, points_mm: np.ndarray) -> np.ndarray:
    """Map points of shape (K, 3) through a rigid 4×4 transform [mm]."""
    return points_mm @ transform[:3, :3].T + transform[:3, 3]


def undistort_pixels(
    x_px: np.ndarray, y_px: np.ndarray, camera_matrix: np.ndarray, dist_coeffs: np.ndarray
) -> np.ndarray:
    """Normalised undistorted image coordinates (x/z, y/z) of distorted pixels, shape (K, 2)."""
    pixels = np.stack([x_px, y_px], axis=-1).astype(GEOMETRY_FLOAT).reshape(-1, 1, 2)
    if pixels.shape[0] == 0:
        return np.zeros((0, 2), GEOMETRY_FLOAT)
    normalised = cv2.undistortPoints(
        pixels, camera_matrix, dist_coeffs, criteria=UNDISTORT_CRITERIA
    )
    return normalised.reshape(-1, 2).astype(GEOMETRY_FLOAT)


def pixels_to_camera_points(
    x_px: np.ndarray, y_px: np.ndarray, sensor: SensorCalibration
) -> np.ndarray:
    """Intersect the rays of centre pixels with the sensor's laser plane (camera frame).

    Parameters
    ----------
    x_px, y_px : ndarray of shape (K,)
        Distorted pixel coordinates (column, row) [px].
    sensor : SensorCalibration

    Returns
    -------
    ndarray of shape (K, 3), float64
        Points on the laser plane in the camera frame [mm].

    Raises
    ------
    PipelineError
        If a ray is (nearly) parallel to the plane or meets it behind the camera.

    Notes
    -----
    With m = (x', y', 1) the undistorted ray and n·P = d the plane, P = (d / n·m) m.
    """
    normalised = undistort_pixels(
        np.asarray(x_px), np.asarray(y_px), sensor.camera_matrix, sensor.dist_coeffs
    )
    rays = np.column_stack([normalised, np.ones(normalised.shape[0])])
    normal = sensor.laser_plane.normal
    cosines = rays @ normal
    length = np.linalg.norm(rays, axis=1)
    if np.any(np.abs(cosines) < MIN_RAY_PLANE_COSINE * length):
        raise PipelineError(f"sensor {sensor.name}: a ray is parallel to the laser plane")
    scale = sensor.laser_plane.d_mm / cosines
    if np.any(scale <= 0):
        raise PipelineError(f"sensor {sensor.name}: a ray meets the laser plane behind the camera")
    return rays * scale[:, None]


def pixels_to_track_points(
    x_px: np.ndarray, y_px: np.ndarray, sensor: SensorCalibration
) -> np.ndarray:
    """Centre pixels → points in the station's track frame, shape (K, 3) [mm]."""
    return apply_transform(sensor.T_track_camera, pixels_to_camera_points(x_px, y_px, sensor))


def project_track_points(points_track_mm: np.ndarray, sensor: SensorCalibration) -> np.ndarray:
    """Project track-frame points through the camera (with lens distortion), shape (K, 2) [px].

    Points must lie in front of the camera (z > 0 in the camera frame).
    """
    points = np.asarray(points_track_mm, dtype=GEOMETRY_FLOAT).reshape(-1, 3)
    if points.shape[0] == 0:
        return np.zeros((0, 2), GEOMETRY_FLOAT)
    camera_points = apply_transform(invert_rigid(sensor.T_track_camera), points)
    pixels, _ = cv2.projectPoints(
        camera_points.reshape(-1, 1, 3),
        np.zeros(3),
        np.zeros(3),
        sensor.camera_matrix,
        sensor.dist_coeffs,
    )
    return pixels.reshape(-1, 2).astype(GEOMETRY_FLOAT)


def camera_centre_track(sensor: SensorCalibration) -> np.ndarray:
    """Position of the camera's projection centre in the track frame, shape (3,) [mm]."""
    return np.array(sensor.T_track_camera[:3, 3])


def laser_plane_track(sensor: SensorCalibration) -> tuple[np.ndarray, float]:
    """The sensor's laser plane in the track frame: (unit normal, d) with n·P = d [mm]."""
    rotation, translation = sensor.T_track_camera[:3, :3], sensor.T_track_camera[:3, 3]
    normal = rotation @ sensor.laser_plane.normal
    return normal, float(sensor.laser_plane.d_mm + normal @ translation)
