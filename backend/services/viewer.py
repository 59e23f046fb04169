"""The 3D view of a wheel (viser): the only module that speaks viser.

For one wheel of one pass it shows, in the station's track frame (metres in the scene):
the wheel reconstructed as the surface of revolution of its fused profile, the centre points
of the four sensors of its axle turned into track-frame points through the pass's
calibration, the four cameras as frusta and their laser planes as translucent squares.
Scene names derive from ids ("/wheels/{wheel_id}/profile"); each request for a view gets a
viser server of its own (from `Settings.viewer_host:viewer_port` up), so one user's view
never changes another's; idle views are closed.

The wheel's diameter is not measured, so the reconstruction uses a nominal rolling radius;
its axial position and height come from the wheel's own sensor points (its back face at
their innermost axial position, its tread through their tread points), so the points sit on
the reconstructed surface wherever the profile and the points agree.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import viser
import viser.transforms as vtf
from sqlalchemy import select
from sqlalchemy.orm import Session

from backend.config import Settings
from backend.errors import NotFoundError
from backend.services.pass_wheels import method_measurement
from backend.services.wheel_data import stored_outline
from backend.storage.artefacts import load_artefacts
from backend.storage.store import BlobStore
from db.models import Measurement, PassWheel, Wheel
from pipeline.calibration.geometry import (
    camera_centre_track,
    laser_plane_track,
    pixels_to_track_points,
)
from pipeline.calibration.model import (
    SENSOR_NAMES,
    SensorCalibration,
    StationCalibration,
    parse_calibration,
)

NOMINAL_RADIUS_MM = 460.0
"""Rolling radius used for the reconstruction (920 mm wheels); the diameter is not measured."""
M_PER_MM = 1e-3
"""viser works in metres; the pipeline in millimetres."""
REVOLUTION_SEGMENTS = 90
MAX_OUTLINE_POINTS = 160
LASER_PLANE_HALF_SIZE_MM = 180.0
TREAD_WINDOW_MM = (55.0, 90.0)
"""Profile x range whose points fix the wheel's height (single-valued tread, around x = 70)."""
VIEW_IDLE_S = 600.0
"""A 3D view with no browser connected for this long is closed [s]."""
MAX_VIEWS = 8
"""Views open at once (each a viser server with its own threads and port)."""
SENSOR_COLOURS = {
    "left_inner": (255, 122, 26),
    "left_outer": (250, 204, 21),
    "right_inner": (34, 195, 238),
    "right_outer": (167, 139, 250),
}


@dataclass(frozen=True, slots=True, eq=False)
class WheelSceneData:
    """Everything the 3D scene of one wheel shows.

    Attributes
    ----------
    wheel_id : int
    side : str
        "left" or "right".
    title : str
        Label shown in the scene.
    profile_x_mm, profile_z_mm : ndarray of shape (K,)
        The profile's outline in the profile frame (`pipeline.profile.outline`), in order
        along the profile (NaN marks gaps).
    points_track_mm : dict of str to ndarray of shape (N, 3)
        Centre points of each sensor of the axle in the track frame [mm].
    calibration : StationCalibration
        The pass's calibration (cameras and laser planes).
    back_face_track_x_mm, reference_track_z_mm : float or None
        Where the measurement put the back face (track X) and the reference point x = 70 mm
        (track Z) [mm]; None when not stored, then both are estimated from the points.
    """

    wheel_id: int
    side: str
    title: str
    profile_x_mm: np.ndarray
    profile_z_mm: np.ndarray
    points_track_mm: dict[str, np.ndarray]
    calibration: StationCalibration
    back_face_track_x_mm: float | None = None
    reference_track_z_mm: float | None = None


@dataclass(frozen=True, slots=True)
class WheelPlacement:
    """Where the reconstructed wheel sits in the track frame [mm]."""

    centre_track_mm: tuple[float, float, float]
    back_face_axial_mm: float
    radius_mm: float


def place_wheel(data: WheelSceneData) -> WheelPlacement:
    """Place the wheel so that its own sensors' points lie on the reconstruction.

    The axle runs along the track X axis, above the median point along the rail (Y). The
    back face and the reference point's height come from the measurement when it stored
    them; otherwise the back face sits at the innermost axial position of the wheel's points
    and the height puts the profile's tread through the points' tread.
    """
    sign = 1.0 if data.side == "right" else -1.0
    own = [p for name, p in data.points_track_mm.items() if name.startswith(data.side) and len(p)]
    points = np.concatenate(own) if own else np.zeros((0, 3))
    along_rail_mm = float(np.median(points[:, 1])) if len(points) else 0.0
    if data.back_face_track_x_mm is not None and data.reference_track_z_mm is not None:
        centre = (0.0, along_rail_mm, data.reference_track_z_mm + NOMINAL_RADIUS_MM)
        return WheelPlacement(centre, sign * data.back_face_track_x_mm, NOMINAL_RADIUS_MM)
    if not len(points):
        return WheelPlacement((0.0, 0.0, NOMINAL_RADIUS_MM), 680.0, NOMINAL_RADIUS_MM)
    axial = sign * points[:, 0]
    back_face = float(np.percentile(axial, 0.5))
    x_mm = axial - back_face
    tread = (x_mm >= TREAD_WINDOW_MM[0]) & (x_mm <= TREAD_WINDOW_MM[1])
    profile_z = _tread_height(data.profile_x_mm, data.profile_z_mm, x_mm[tread])
    usable = np.isfinite(profile_z)
    if np.any(usable):
        lowest = float(np.median(points[tread][usable, 2] + profile_z[usable]))
    else:
        lowest = float(np.min(points[:, 2]))
    centre = (0.0, along_rail_mm, lowest + NOMINAL_RADIUS_MM)
    return WheelPlacement(centre, back_face, NOMINAL_RADIUS_MM)


def _tread_height(x_mm: np.ndarray, z_mm: np.ndarray, at_mm: np.ndarray) -> np.ndarray:
    """Profile z at the given x inside the tread window (single-valued there, so sortable)."""
    keep = np.isfinite(x_mm) & np.isfinite(z_mm)
    keep &= (x_mm >= TREAD_WINDOW_MM[0] - 5) & (x_mm <= TREAD_WINDOW_MM[1] + 5)
    if np.count_nonzero(keep) < 2:
        return np.full(at_mm.shape, np.nan)
    order = np.argsort(x_mm[keep])
    return np.interp(at_mm, x_mm[keep][order], z_mm[keep][order], left=np.nan, right=np.nan)


def revolve_profile(
    x_mm: np.ndarray, z_mm: np.ndarray, side: str, placement: WheelPlacement
) -> tuple[np.ndarray, np.ndarray]:
    """Surface of revolution of a profile about the axle: vertices (V, 3) [mm], faces (F, 3).

    Profile points stay in their order along the profile (the flange is multi-valued in x);
    no face spans a gap (NaN) of the profile.
    """
    x, z = _decimate(np.asarray(x_mm, float), np.asarray(z_mm, float), MAX_OUTLINE_POINTS)
    sign = 1.0 if side == "right" else -1.0
    phi = np.linspace(0.0, 2 * np.pi, REVOLUTION_SEGMENTS, endpoint=False)
    radius = placement.radius_mm + z
    axial = sign * (placement.back_face_axial_mm + x)
    centre = np.asarray(placement.centre_track_mm)
    vertices = np.empty((len(x), len(phi), 3))
    vertices[..., 0] = centre[0] + axial[:, None]
    vertices[..., 1] = centre[1] + radius[:, None] * np.cos(phi)[None, :]
    vertices[..., 2] = centre[2] + radius[:, None] * np.sin(phi)[None, :]
    k = np.arange(len(x) - 1)[np.isfinite(x[:-1] + x[1:] + z[:-1] + z[1:])]
    j = np.arange(len(phi))
    a = (k[:, None] * len(phi) + j[None, :]).ravel()
    b = (k[:, None] * len(phi) + (j[None, :] + 1) % len(phi)).ravel()
    c, d = a + len(phi), b + len(phi)
    faces = np.concatenate([np.stack([a, c, b], 1), np.stack([b, c, d], 1)])
    return np.nan_to_num(vertices.reshape(-1, 3)), faces.astype(np.uint32)


def _decimate(x: np.ndarray, z: np.ndarray, count: int) -> tuple[np.ndarray, np.ndarray]:
    step = max(1, int(np.ceil(len(x) / count)))
    return x[::step], z[::step]


def laser_plane_square(
    sensor: SensorCalibration, near_track_mm: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """A square of the sensor's laser plane centred where it passes nearest a point [mm]."""
    normal, d = laser_plane_track(sensor)
    centre = near_track_mm - (normal @ near_track_mm - d) * normal
    up = np.array([0.0, 0.0, 1.0]) - normal[2] * normal
    if np.linalg.norm(up) < 1e-6:
        up = np.array([0.0, 1.0, 0.0]) - normal[1] * normal
    up /= np.linalg.norm(up)
    across = np.cross(normal, up)
    h = LASER_PLANE_HALF_SIZE_MM
    corners = [
        centre + h * (su * up + sa * across) for su, sa in ((-1, -1), (-1, 1), (1, 1), (1, -1))
    ]
    return np.array(corners), np.array([[0, 1, 2], [0, 2, 3]], np.uint32)


def tread_point(side: str, placement: WheelPlacement) -> np.ndarray:
    """Track-frame position of the reference point (x = 70 mm) at the wheel's bottom [mm]."""
    sign = 1.0 if side == "right" else -1.0
    centre = np.asarray(placement.centre_track_mm)
    axial = sign * (placement.back_face_axial_mm + 70.0)
    return centre + np.array([axial, 0.0, -placement.radius_mm])


def build_wheel_scene(scene: viser.SceneApi, data: WheelSceneData) -> viser.FrameHandle:
    """Add the wheel, the sensor points, the cameras and the laser planes under /wheels/{id};
    returns the root node (its visibility shows or hides the whole wheel)."""
    root = f"/wheels/{data.wheel_id}"
    root_node = scene.add_frame(root, show_axes=False)
    placement = place_wheel(data)
    vertices, faces = revolve_profile(data.profile_x_mm, data.profile_z_mm, data.side, placement)
    scene.add_mesh_simple(
        f"{root}/profile", vertices * M_PER_MM, faces, color=(170, 178, 189), side="double"
    )
    wheel_centre = np.asarray(placement.centre_track_mm)
    tread_mm = tread_point(data.side, placement)
    for name, points in data.points_track_mm.items():
        if len(points):
            scene.add_point_cloud(
                f"{root}/points/{name}", points * M_PER_MM, SENSOR_COLOURS[name], point_size=0.002
            )
    for sensor in data.calibration.sensors:
        _add_sensor(scene, root, sensor, data.points_track_mm.get(sensor.name), wheel_centre)
    scene.add_label(f"{root}/label", data.title, position=tuple(tread_mm * M_PER_MM))
    return root_node


def _add_sensor(
    scene: viser.SceneApi,
    root: str,
    sensor: SensorCalibration,
    points: np.ndarray | None,
    wheel_centre_mm: np.ndarray,
) -> None:
    colour = SENSOR_COLOURS.get(sensor.name, (200, 200, 200))
    rotation = sensor.T_track_camera[:3, :3]
    fy = float(sensor.camera_matrix[1, 1])
    scene.add_camera_frustum(
        f"{root}/cameras/{sensor.name}",
        fov=2 * np.arctan2(sensor.image_height_px / 2, fy),
        aspect=sensor.image_width_px / sensor.image_height_px,
        scale=0.08,
        color=colour,
        wxyz=vtf.SO3.from_matrix(rotation).wxyz,
        position=tuple(camera_centre_track(sensor) * M_PER_MM),
    )
    near = points.mean(axis=0) if points is not None and len(points) else wheel_centre_mm
    corners, faces = laser_plane_square(sensor, near)
    scene.add_mesh_simple(
        f"{root}/laser_planes/{sensor.name}",
        corners * M_PER_MM,
        faces,
        color=colour,
        opacity=0.18,
        side="double",
    )


@dataclass(slots=True, eq=False)
class _ViewSession:
    """One browser's 3D view: its own viser server (own port, own scene)."""

    server: viser.ViserServer
    wheel_id: int
    seen_at_s: float
    """Last time (monotonic) a client was connected, or the view was opened."""


class WheelViewer:
    """The service's 3D views: one viser server per request, so each browser has a scene of
    its own (one shared scene let a second user switch the wheel the first was viewing).

    Servers start at `Settings.viewer_port` (viser takes the next free port when it is
    taken). A view nobody has been connected to for `VIEW_IDLE_S` is closed when the next
    one opens; beyond `MAX_VIEWS` the least recently seen is closed.
    """

    def __init__(self, settings: Settings, clock: Callable[[], float] = time.monotonic) -> None:
        self._host = settings.viewer_host
        self._port = settings.viewer_port
        self._clock = clock
        self._views: dict[int, _ViewSession] = {}
        self._lock = threading.Lock()

    def show(self, data: WheelSceneData) -> int:
        """Open a new view of the wheel; returns its viser server's port."""
        with self._lock:
            now = self._clock()
            self._expire(now)
            server = viser.ViserServer(host=self._host, port=self._port, verbose=False)
            server.scene.set_up_direction("+z")
            # embedded in a narrow panel: the review app's dark look, and viser's own
            # control panel (scene tree, developer settings) folded away
            server.gui.configure_theme(dark_mode=True, show_logo=False, show_share_button=False)
            server.gui.main_panel.minimize()
            build_wheel_scene(server.scene, data)
            target = tread_point(data.side, place_wheel(data)) * M_PER_MM
            sign = 1.0 if data.side == "right" else -1.0
            server.initial_camera.look_at = tuple(target)
            server.initial_camera.position = tuple(target + np.array([sign * 0.9, -1.3, 0.7]))
            port = server.get_port()
            self._views[port] = _ViewSession(server, data.wheel_id, now)
            return port

    def open_ports(self) -> list[int]:
        """Ports of the views still open."""
        with self._lock:
            return sorted(self._views)

    def _expire(self, now: float) -> None:
        for port, view in list(self._views.items()):
            if view.server.get_clients():
                view.seen_at_s = now
            elif now - view.seen_at_s > VIEW_IDLE_S:
                self._close(port)
        while len(self._views) >= MAX_VIEWS:
            self._close(min(self._views, key=lambda p: self._views[p].seen_at_s))

    def _close(self, port: int) -> None:
        self._views.pop(port).server.stop()

    def stop(self) -> None:
        """Stop every view's server."""
        with self._lock:
            for port in list(self._views):
                self._close(port)


def load_wheel_scene_data(
    session: Session, store: BlobStore, pass_wheel: PassWheel, method: str
) -> WheelSceneData:
    """Gather the scene of a wheel in a pass from the database and the artefact store."""
    pass_id, wheel_id = pass_wheel.pass_id, pass_wheel.wheel_id
    measurement = method_measurement(pass_wheel, method)
    # A wheel not measured keeps its track points but has no fused profile (no "x_mm").
    if measurement is None or "x_mm" not in (measurement.profile or {}):
        raise NotFoundError(
            f"wheel {wheel_id} of pass {pass_id} has no {method} profile to show in 3D"
            f" (state: {pass_wheel.state})"
        )
    calibration = parse_calibration(pass_wheel.train_pass.calibration.document)
    wheel = pass_wheel.wheel
    points: dict[str, np.ndarray] = {}
    for axle_wheel in _axle_pass_wheels(session, pass_wheel):
        axle_measurement = method_measurement(axle_wheel, method)
        if axle_measurement is not None:
            points.update(_track_points(store, axle_measurement, calibration))
    profile = measurement.profile or {}
    outline = stored_outline(profile)
    return WheelSceneData(
        wheel_id=wheel_id,
        side=wheel.side,
        title=f"vehicle {wheel.vehicle_id} · axle {wheel.axle} · {wheel.side} · {method}",
        profile_x_mm=outline[:, 0],
        profile_z_mm=outline[:, 1],
        points_track_mm=points,
        calibration=calibration,
        back_face_track_x_mm=profile.get("back_face_track_x_mm"),
        reference_track_z_mm=profile.get("reference_track_z_mm"),
    )


def _axle_pass_wheels(session: Session, pass_wheel: PassWheel) -> list[PassWheel]:
    """Both wheels of the axle of `pass_wheel` in the same pass."""
    wheel = pass_wheel.wheel
    return list(
        session.scalars(
            select(PassWheel)
            .join(Wheel, PassWheel.wheel_id == Wheel.id)
            .where(
                PassWheel.pass_id == pass_wheel.pass_id,
                Wheel.vehicle_id == wheel.vehicle_id,
                Wheel.axle == wheel.axle,
            )
        )
    )


def _track_points(
    store: BlobStore, measurement: Measurement, calibration: StationCalibration
) -> dict[str, np.ndarray]:
    """Centre points of each frame of a measurement in the track frame, per sensor [mm]."""
    per_sensor: dict[str, list[np.ndarray]] = {}
    for frame in measurement.frames:
        if frame.sensor not in SENSOR_NAMES or frame.sensor not in calibration.sensor_names:
            continue
        artefacts = load_artefacts(store, frame.artefact_sha256)
        x, y = artefacts.points["x"], artefacts.points["y"]
        if len(x):
            track = pixels_to_track_points(x, y, calibration.sensor(frame.sensor))
            per_sensor.setdefault(frame.sensor, []).append(track)
    return {name: np.concatenate(chunks) for name, chunks in per_sensor.items()}
