"""The 3D wheel scene: reconstruction geometry, placement from the sensor points, and a real
viser server building the scene."""

from __future__ import annotations

import socket

import numpy as np
import pytest

from backend.services.viewer import (
    NOMINAL_RADIUS_MM,
    WheelPlacement,
    WheelSceneData,
    build_wheel_scene,
    laser_plane_square,
    place_wheel,
    revolve_profile,
)
from pipeline.calibration.geometry import laser_plane_track
from pipeline.simulation.station import build_station


def flange_profile() -> tuple[np.ndarray, np.ndarray]:
    """A profile ordered along itself: up the back face, over the flange, along the tread
    (multi-valued in x at the flange), with a gap (NaN) in the middle of the tread."""
    up = np.linspace(-10.0, 25.0, 20)
    back = np.column_stack([np.zeros_like(up), up])
    t = np.linspace(np.pi, 0.0, 30)
    flange = np.column_stack([12.0 + 12.0 * np.cos(t), 25.0 + 4.0 * np.sin(t)])
    flank = np.column_stack([np.linspace(24.0, 20.0, 10), np.linspace(25.0, 5.0, 10)])
    tread = np.column_stack([np.linspace(21.0, 130.0, 60), np.linspace(4.0, -1.0, 60)])
    tread[30] = np.nan
    xz = np.concatenate([back, flange, flank, tread])
    return xz[:, 0], xz[:, 1]


def wheel_points(
    x_mm: np.ndarray, z_mm: np.ndarray, placement: WheelPlacement, sign: float, phi_rad: float
) -> np.ndarray:
    ok = np.isfinite(x_mm)
    centre = np.asarray(placement.centre_track_mm)
    radius = placement.radius_mm + z_mm[ok]
    return np.column_stack(
        [
            centre[0] + sign * (placement.back_face_axial_mm + x_mm[ok]),
            centre[1] + radius * np.cos(phi_rad),
            centre[2] + radius * np.sin(phi_rad),
        ]
    )


def scene_data(side: str, points: dict[str, np.ndarray]) -> WheelSceneData:
    x_mm, z_mm = flange_profile()
    return WheelSceneData(
        wheel_id=7,
        side=side,
        title="vehicle V1 · axle 1",
        profile_x_mm=x_mm,
        profile_z_mm=z_mm,
        points_track_mm=points,
        calibration=build_station().calibration,
    )


def test_revolved_vertices_lie_at_radius_plus_profile_height() -> None:
    x_mm, z_mm = flange_profile()
    placement = WheelPlacement((0.0, 50.0, 460.0), 680.0, NOMINAL_RADIUS_MM)
    vertices, faces = revolve_profile(x_mm, z_mm, "right", placement)
    rings = vertices.reshape(len(x_mm), -1, 3)
    ok = np.isfinite(x_mm)
    radial = np.hypot(rings[ok, :, 1] - 50.0, rings[ok, :, 2] - 460.0)
    np.testing.assert_allclose(
        radial, np.broadcast_to((NOMINAL_RADIUS_MM + z_mm[ok])[:, None], radial.shape), atol=1e-9
    )
    np.testing.assert_allclose(rings[ok, 0, 0], 680.0 + x_mm[ok], atol=1e-9)
    assert faces.max() < len(vertices)


def test_no_face_spans_a_gap_in_the_profile() -> None:
    x_mm, z_mm = flange_profile()
    placement = WheelPlacement((0.0, 0.0, 460.0), 680.0, NOMINAL_RADIUS_MM)
    vertices, faces = revolve_profile(x_mm, z_mm, "left", placement)
    segments = len(vertices) // len(x_mm)
    gap_ring = int(np.flatnonzero(~np.isfinite(x_mm))[0])
    assert not np.any(faces // segments == gap_ring)
    used = np.unique(faces)
    assert np.all(vertices[used, 0] <= -680.0 + 1e-9)


@pytest.mark.parametrize(("side", "sign"), [("right", 1.0), ("left", -1.0)])
def test_placement_puts_the_wheel_through_its_own_sensor_points(side: str, sign: float) -> None:
    x_mm, z_mm = flange_profile()
    truth = WheelPlacement((0.0, 12.0, 455.0), 679.5, NOMINAL_RADIUS_MM)
    points = wheel_points(x_mm, z_mm, truth, sign, -np.pi / 2)
    placed = place_wheel(scene_data(side, {f"{side}_inner": points}))
    assert placed.back_face_axial_mm == pytest.approx(679.5, abs=0.5)
    assert placed.centre_track_mm[2] == pytest.approx(455.0, abs=0.2)
    assert placed.centre_track_mm[1] == pytest.approx(12.0, abs=1e-6)


def test_laser_plane_square_lies_in_the_sensors_plane() -> None:
    sensor = build_station().calibration.sensor("right_inner")
    corners, faces = laser_plane_square(sensor, np.array([700.0, 0.0, 20.0]))
    normal, d = laser_plane_track(sensor)
    np.testing.assert_allclose(corners @ normal, d, atol=1e-6)
    assert faces.shape == (2, 3)


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def test_scene_builds_on_a_real_viser_server_under_wheel_ids() -> None:
    viser = pytest.importorskip("viser")
    x_mm, z_mm = flange_profile()
    truth = WheelPlacement((0.0, 0.0, 460.0), 680.0, NOMINAL_RADIUS_MM)
    points = {"right_inner": wheel_points(x_mm, z_mm, truth, 1.0, -np.pi / 2)}
    server = viser.ViserServer(host="127.0.0.1", port=free_port(), verbose=False)
    try:
        root = build_wheel_scene(server.scene, scene_data("right", points))
        assert root.name == "/wheels/7"
        root.visible = False
    finally:
        server.stop()


def test_each_view_is_a_scene_of_its_own_and_idle_ones_close() -> None:
    pytest.importorskip("viser")
    from backend.config import Settings
    from backend.services.viewer import VIEW_IDLE_S, WheelViewer

    now = [0.0]
    viewer = WheelViewer(Settings(viewer_port=free_port()), clock=lambda: now[0])
    x_mm, z_mm = flange_profile()
    truth = WheelPlacement((0.0, 0.0, 460.0), 680.0, NOMINAL_RADIUS_MM)
    points = {"right_inner": wheel_points(x_mm, z_mm, truth, 1.0, -np.pi / 2)}
    try:
        first = viewer.show(scene_data("right", points))
        second = viewer.show(scene_data("right", points))
        # a second user's view is another server: the first user's scene stays as it was
        assert first != second and viewer.open_ports() == sorted([first, second])
        now[0] = VIEW_IDLE_S + 1.0  # nobody connected to either since
        third = viewer.show(scene_data("right", points))
        assert viewer.open_ports() == [third]
    finally:
        viewer.stop()
    assert viewer.open_ports() == []
