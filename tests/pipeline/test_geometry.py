"""Pixel ↔ millimetre transforms: hand-checked numbers and property round trips."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pipeline.calibration.geometry import (
    invert_rigid,
    laser_plane_track,
    pixels_to_camera_points,
    pixels_to_track_points,
    project_track_points,
    rigid_transform,
)
from pipeline.calibration.model import LaserPlane, SensorCalibration
from pipeline.errors import PipelineError
from pipeline.simulation.station import build_station

ROT_Z_90 = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])


def _pinhole(transform: np.ndarray | None = None, dist=(0.0, 0.0, 0.0, 0.0, 0.0)):
    return SensorCalibration(
        name="right_inner",
        image_width_px=1000,
        image_height_px=800,
        bit_depth=8,
        camera_matrix=np.array([[1000.0, 0.0, 500.0], [0.0, 1000.0, 400.0], [0.0, 0.0, 1.0]]),
        dist_coeffs=np.array(dist),
        laser_plane=LaserPlane(normal=np.array([0.0, 0.0, 1.0]), d_mm=500.0),
        T_track_camera=np.eye(4) if transform is None else transform,
    )


def test_pixel_to_plane_point_by_hand() -> None:
    # Pixel (600, 400): ray (0.1, 0, 1); plane z = 500 → P = 500·(0.1, 0, 1) = (50, 0, 500).
    points = pixels_to_camera_points(np.array([600.0, 500.0]), np.array([400.0, 300.0]), _pinhole())
    np.testing.assert_allclose(points, [[50.0, 0.0, 500.0], [0.0, -50.0, 500.0]], atol=1e-9)


def test_camera_to_track_by_hand() -> None:
    # Rz(90°) maps (50, 0, 500) to (0, 50, 500); plus t = (10, 20, 30) → (10, 70, 530).
    sensor = _pinhole(rigid_transform(ROT_Z_90, np.array([10.0, 20.0, 30.0])))
    points = pixels_to_track_points(np.array([600.0]), np.array([400.0]), sensor)
    np.testing.assert_allclose(points, [[10.0, 70.0, 530.0]], atol=1e-9)


def test_laser_plane_in_track_frame_by_hand() -> None:
    # Camera plane z = 500 with R = Rz(90°), t = (10, 20, 30): n = (0, 0, 1), d = 530.
    sensor = _pinhole(rigid_transform(ROT_Z_90, np.array([10.0, 20.0, 30.0])))
    normal, d = laser_plane_track(sensor)
    np.testing.assert_allclose(normal, [0.0, 0.0, 1.0], atol=1e-12)
    assert d == pytest.approx(530.0)


def test_projection_by_hand_with_radial_distortion() -> None:
    # (50, 0, 500): normalised (0.1, 0); k1 = −0.2 → 0.1·(1 − 0.2·0.01) = 0.0998 → x = 599.8.
    sensor = _pinhole(dist=(-0.2, 0.0, 0.0, 0.0, 0.0))
    pixels = project_track_points(np.array([[50.0, 0.0, 500.0]]), sensor)
    np.testing.assert_allclose(pixels, [[599.8, 400.0]], atol=1e-9)
    back = pixels_to_camera_points(pixels[:, 0], pixels[:, 1], sensor)
    np.testing.assert_allclose(back, [[50.0, 0.0, 500.0]], atol=1e-9)


def test_ray_parallel_to_the_plane_is_a_pipeline_error() -> None:
    sensor = _pinhole()
    sensor = SensorCalibration(
        **{
            **{f: getattr(sensor, f) for f in SensorCalibration.__slots__},
            "laser_plane": LaserPlane(np.array([0.0, 0.0, 1.0]), -500.0),
        }
    )
    with pytest.raises(PipelineError, match="behind the camera"):
        pixels_to_camera_points(np.array([500.0]), np.array([400.0]), sensor)


angles = st.floats(-np.pi, np.pi, allow_nan=False)


@given(angles, angles, angles, st.tuples(*[st.floats(-1e3, 1e3)] * 3))
def test_rigid_transform_inverse_is_identity(a: float, b: float, c: float, t) -> None:
    ca, sa, cb, sb, cc, sc = np.cos(a), np.sin(a), np.cos(b), np.sin(b), np.cos(c), np.sin(c)
    rz = np.array([[ca, -sa, 0], [sa, ca, 0], [0, 0, 1]])
    ry = np.array([[cb, 0, sb], [0, 1, 0], [-sb, 0, cb]])
    rx = np.array([[1, 0, 0], [0, cc, -sc], [0, sc, cc]])
    transform = rigid_transform(rz @ ry @ rx, np.array(t))
    np.testing.assert_allclose(transform @ invert_rigid(transform), np.eye(4), atol=1e-9)


STATION = build_station()


@settings(max_examples=60, deadline=None)
@given(
    st.sampled_from([s.name for s in STATION.calibration.sensors]),
    st.floats(40.0, 1560.0),
    st.floats(40.0, 1160.0),
)
def test_pixel_to_mm_to_pixel_round_trip(name: str, x_px: float, y_px: float) -> None:
    sensor = STATION.calibration.sensor(name)
    points = pixels_to_track_points(np.array([x_px]), np.array([y_px]), sensor)
    normal, d = laser_plane_track(sensor)
    assert float(points[0] @ normal) == pytest.approx(d, abs=1e-6)
    again = project_track_points(points, sensor)
    np.testing.assert_allclose(again, [[x_px, y_px]], atol=1e-6)


@settings(max_examples=60, deadline=None)
@given(
    st.sampled_from([s.name for s in STATION.calibration.sensors]),
    st.floats(-60.0, 60.0),
    st.floats(-50.0, 50.0),
)
def test_mm_to_pixel_to_mm_round_trip(name: str, dx_mm: float, dz_mm: float) -> None:
    sensor = STATION.calibration.sensor(name)
    normal, d = laser_plane_track(sensor)
    side = -1.0 if name.startswith("left") else 1.0
    guess = np.array([side * 740.0 + dx_mm, 0.0, dz_mm])
    point = guess + (d - guess @ normal) * normal
    pixels = project_track_points(point[None, :], sensor)
    back = pixels_to_track_points(pixels[:, 0], pixels[:, 1], sensor)
    np.testing.assert_allclose(back, point[None, :], atol=1e-6)
