"""Physically based stripe geometry: where a sensor's laser plane meets a wheel, as seen.

`wheel_section` intersects the laser plane exactly with the wheel's surface of revolution,
keeps the points the laser lights and the camera sees (facing both, and not hidden behind
another part of the wheel), and projects them through the camera with lens distortion.
Each point carries the stripe's image width, from the laser sheet's thickness spread by the
incidence angle and foreshortened by the viewing angle and range, and its irradiance.
`render_stripes` (in `pipeline.simulation.frame_render`) turns such polylines into a grey frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pipeline.calibration.geometry import (
    camera_centre_track,
    laser_plane_track,
    project_track_points,
)
from pipeline.calibration.model import SensorCalibration
from pipeline.imaging import GEOMETRY_FLOAT
from pipeline.simulation.station import NOMINAL_BACK_TO_BACK_MM, PIXEL_PITCH_MM, Station
from pipeline.simulation.wheel import WheelProfile, outward_normals, radius_envelope

SHEET_THICKNESS_MM = 0.5
"""1/e² thickness of the laser sheet at the wheel [mm] (< 180 µm at the waist, spread by
the 45° fan's depth of field)."""
PSF_PX = 2.0
"""1/e² width of the in-focus lens and pixel response [px]."""
F_NUMBER = 1.8
FOCUS_DISTANCE_MM = 600.0
"""The 16 mm lens works nearly wide open and is focused beyond the wheel, so nearer parts
of the profile blur more (the paper: near regions wide, far regions narrow)."""
OCCLUSION_STEPS = 96
OCCLUSION_REACH_MM = 260.0
"""Rays are marched this far towards the camera and the laser; beyond it they leave the rim."""
OCCLUSION_START_MM = 0.4
OCCLUSION_MARGIN_MM = 0.05
"""A ray point counts as inside the wheel only when 0.05 mm below its surface, so the
surface point a ray starts from never hides itself."""


@dataclass(frozen=True, slots=True)
class WheelPose:
    """Where a wheel is in the track frame when a frame is taken.

    Attributes
    ----------
    centre_track_mm : tuple of float
        Axle centre (X, Y, Z) of the wheelset [mm].
    axle_direction : tuple of float
        Unit axle direction, towards the right wheel (yaw turns it about Z).
    side_sign : int
        +1 for the right wheel, −1 for the left one.
    back_face_axial_mm : float
        Axial distance from the axle centre to this wheel's back face (half back-to-back).
    radius_mm : float
        Rolling radius at the reference point (z = 0 of the profile) [mm].
    """

    centre_track_mm: tuple[float, float, float]
    axle_direction: tuple[float, float, float]
    side_sign: int
    back_face_axial_mm: float
    radius_mm: float


@dataclass(frozen=True, slots=True, eq=False)
class StripeSamples:
    """A stripe as seen by a camera: ordered samples, in runs of consecutive visible points.

    Attributes
    ----------
    pixels : ndarray of shape (K, 2), float64
        True centre-line positions (x, y) [px].
    width_px : ndarray of shape (K,)
        1/e² full width of the Gaussian cross-section [px].
    irradiance : ndarray of shape (K,)
        Relative laser irradiance times the cosine law (0..1), before reflectivity.
    outline_index : ndarray of shape (K,), int64
        Index of each sample in the wheel outline (−1 for other parts).
    run_id : ndarray of shape (K,), int64
        Consecutive samples with the same run id are joined by the stripe.
    points_track_mm : ndarray of shape (K, 3)
        The samples in the track frame [mm].
    """

    pixels: np.ndarray
    width_px: np.ndarray
    irradiance: np.ndarray
    outline_index: np.ndarray
    run_id: np.ndarray
    points_track_mm: np.ndarray


def _surface_points(profile: WheelProfile, pose: WheelPose, normal: np.ndarray, d: float):
    """Exact plane ∩ surface of revolution: points, outward normals and a validity mask."""
    a = np.asarray(pose.axle_direction, GEOMETRY_FLOAT)
    centre = np.asarray(pose.centre_track_mm, GEOMETRY_FLOAT)
    e1 = np.array([-a[1], a[0], 0.0])
    e2 = np.array([0.0, 0.0, 1.0])
    u = pose.side_sign * (pose.back_face_axial_mm + profile.x_mm)
    r = pose.radius_mm + profile.z_mm
    # P(φ) = C + u·a + r(cos φ e1 + sin φ e2); n·P = d  ⇔  A cos φ + B sin φ = D.
    big_a, big_b = r * (normal @ e1), r * (normal @ e2)
    big_d = d - normal @ centre - u * (normal @ a)
    amplitude = np.hypot(big_a, big_b)
    valid = np.abs(big_d) < amplitude
    phi = np.arctan2(big_b, big_a) - np.arccos(np.clip(big_d / amplitude, -1.0, 1.0))
    radial = np.cos(phi)[:, None] * e1 + np.sin(phi)[:, None] * e2
    points = centre + u[:, None] * a + r[:, None] * radial
    n2 = outward_normals(profile.x_mm, profile.z_mm)
    normals = pose.side_sign * n2[:, :1] * a + n2[:, 1:] * radial
    return points, normals, valid


def _inside_wheel(points: np.ndarray, profile: WheelProfile, pose: WheelPose) -> np.ndarray:
    a = np.asarray(pose.axle_direction, GEOMETRY_FLOAT)
    w = points - np.asarray(pose.centre_track_mm, GEOMETRY_FLOAT)
    u = w @ a
    radial = np.linalg.norm(w - u[..., None] * a, axis=-1)
    x = pose.side_sign * u - pose.back_face_axial_mm
    z = radial - pose.radius_mm
    return z < radius_envelope(profile, x) - OCCLUSION_MARGIN_MM


def _unoccluded(points: np.ndarray, towards: np.ndarray, profile, pose) -> np.ndarray:
    direction = towards - points
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    steps = np.linspace(OCCLUSION_START_MM, OCCLUSION_REACH_MM, OCCLUSION_STEPS)
    ray = points[:, None, :] + steps[None, :, None] * direction[:, None, :]
    return ~np.any(_inside_wheel(ray, profile, pose), axis=1)


def _runs(visible: np.ndarray) -> np.ndarray:
    """Run id per sample: increments at every gap, so runs are consecutive visible samples."""
    return np.cumsum(np.concatenate([[1], np.diff(visible.astype(np.int8)) != 0]))


def _defocus_px(ranges_mm: np.ndarray, sensor: SensorCalibration) -> np.ndarray:
    """Blur-circle diameter of a thin lens focused at FOCUS_DISTANCE_MM [px]."""
    focal_mm = sensor.camera_matrix[0, 0] * PIXEL_PITCH_MM
    blur_mm = focal_mm**2 / (F_NUMBER * (FOCUS_DISTANCE_MM - focal_mm))
    return blur_mm * np.abs(ranges_mm - FOCUS_DISTANCE_MM) / ranges_mm / PIXEL_PITCH_MM


def _image_widths(points, normals, pixels, plane_normal, sensor, scatter_mm) -> np.ndarray:
    tangent = np.gradient(points, axis=0)
    across = np.cross(normals, tangent)
    across /= np.linalg.norm(across, axis=1, keepdims=True)
    # The sheet (thickness t along the plane normal) lights a band t / |n·m| wide along m;
    # light scattered inside a rough surface widens it further (added in quadrature).
    band_mm = np.hypot(SHEET_THICKNESS_MM, scatter_mm) / np.maximum(
        np.abs(across @ plane_normal), 0.05
    )
    ends = project_track_points(points + 0.5 * band_mm[:, None] * across, sensor)
    image_tangent = np.gradient(pixels, axis=0)
    image_tangent /= np.maximum(np.linalg.norm(image_tangent, axis=1, keepdims=True), 1e-12)
    offset = ends - pixels
    perpendicular = np.abs(offset[:, 0] * image_tangent[:, 1] - offset[:, 1] * image_tangent[:, 0])
    ranges = np.linalg.norm(points - camera_centre_track(sensor), axis=1)
    return np.sqrt((2 * perpendicular) ** 2 + _defocus_px(ranges, sensor) ** 2 + PSF_PX**2)


def wheel_section(
    profile: WheelProfile,
    pose: WheelPose,
    sensor: SensorCalibration,
    laser_origin_mm: np.ndarray,
    *,
    scatter_mm: np.ndarray,
) -> StripeSamples:
    """The sensor's view of its laser stripe on a wheel.

    Parameters
    ----------
    profile : WheelProfile
    pose : WheelPose
    sensor : SensorCalibration
        The true calibration of the sensor.
    laser_origin_mm : ndarray of shape (3,)
        Laser emitter position in the track frame [mm].
    scatter_mm : ndarray of shape (K,)
        Sub-surface/roughness spread of the light at each outline point at normal
        incidence [mm]; it grows as 1/cos towards grazing laser incidence.

    Returns
    -------
    StripeSamples
        Only the lit, visible samples inside the image.
    """
    plane_normal, plane_d = laser_plane_track(sensor)
    points, normals, valid = _surface_points(profile, pose, plane_normal, plane_d)
    camera = camera_centre_track(sensor)
    to_laser = laser_origin_mm - points
    cos_laser = np.einsum("ij,ij->i", normals, to_laser) / np.linalg.norm(to_laser, axis=1)
    cos_camera = np.einsum("ij,ij->i", normals, camera - points)
    visible = valid & (cos_laser > 0.02) & (cos_camera > 0)
    candidates = np.flatnonzero(visible)
    visible[candidates] = _unoccluded(points[candidates], camera, profile, pose) & _unoccluded(
        points[candidates], laser_origin_mm, profile, pose
    )
    pixels = project_track_points(points, sensor)
    inside = (
        (pixels[:, 0] >= 0)
        & (pixels[:, 0] <= sensor.image_width_px - 1)
        & (pixels[:, 1] >= 0)
        & (pixels[:, 1] <= sensor.image_height_px - 1)
    )
    visible &= inside
    scatter = scatter_mm / np.maximum(cos_laser, 0.3)
    widths = _image_widths(points, normals, pixels, plane_normal, sensor, scatter)
    run_id = _runs(visible)
    keep = np.flatnonzero(visible)
    return StripeSamples(
        pixels=pixels[keep],
        width_px=widths[keep],
        irradiance=np.clip(cos_laser[keep], 0.0, 1.0),
        outline_index=keep.astype(np.int64),
        run_id=run_id[keep],
        points_track_mm=points[keep],
    )


CENTRED_RADIUS_MM = 410.0
"""Rolling radius of `centred_view`'s wheel [mm] (the simulated trains' 400–420)."""


def centred_view(
    station: Station, name: str, profile: WheelProfile, *, scatter_mm: float = 0.5
) -> tuple[WheelPose, StripeSamples]:
    """A wheel of an LM wheelset centred on the track (axle along X, no yaw, its lowest
    section in the laser planes) as sensor `name` of `station` sees its stripe.

    Parameters
    ----------
    station : Station
    name : str
        Sensor name, e.g. "right_outer" (its side places the wheel).
    profile : WheelProfile
    scatter_mm : float
        Spread of the light in the surface at normal incidence, the same everywhere [mm].

    Returns
    -------
    (WheelPose, StripeSamples)
    """
    pose = WheelPose(
        centre_track_mm=(0.0, 0.0, CENTRED_RADIUS_MM),
        axle_direction=(1.0, 0.0, 0.0),
        side_sign=1 if name.startswith("right") else -1,
        back_face_axial_mm=NOMINAL_BACK_TO_BACK_MM["LMA"] / 2,
        radius_mm=CENTRED_RADIUS_MM,
    )
    samples = wheel_section(
        profile,
        pose,
        station.calibration.sensor(name),
        station.laser_origin(name),
        scatter_mm=np.full(profile.x_mm.size, scatter_mm),
    )
    return pose, samples


def band_edge_pixels(
    profile: WheelProfile,
    pose: WheelPose,
    sensor: SensorCalibration,
    samples: StripeSamples,
    offset_mm: float,
) -> np.ndarray:
    """Where the laser plane moved `offset_mm` along its normal meets the wheel at each
    sample's outline point, in the image (K, 2) [px]: an edge of the lit band when the
    offset is half the band's thickness. Samples the moved plane misses keep their pixel.
    """
    normal, d = laser_plane_track(sensor)
    points, _, valid = _surface_points(profile, pose, normal, d + offset_mm)
    index = samples.outline_index
    pixels = project_track_points(points[index], sensor)
    return np.where(valid[index][:, None], pixels, samples.pixels)


def plate_section(
    sensor: SensorCalibration,
    laser_origin_mm: np.ndarray,
    *,
    plate_x_mm: float,
    z_range_mm: tuple[float, float],
    scatter_mm: float,
) -> StripeSamples:
    """The stripe the laser draws on a flat vertical face X = plate_x (an axle box or brake
    part beside the wheel), as the camera sees it; empty when it is out of view or unlit."""
    plane_normal, plane_d = laser_plane_track(sensor)
    z = np.linspace(z_range_mm[0], z_range_mm[1], 1200)
    y = (plane_d - plane_normal[0] * plate_x_mm - plane_normal[2] * z) / plane_normal[1]
    points = np.column_stack([np.full_like(z, plate_x_mm), y, z])
    camera = camera_centre_track(sensor)
    normal = np.array([np.sign(camera[0] - plate_x_mm), 0.0, 0.0])
    normals = np.broadcast_to(normal, points.shape)
    to_laser = laser_origin_mm - points
    cos_laser = to_laser @ normal / np.linalg.norm(to_laser, axis=1)
    pixels = project_track_points(points, sensor)
    visible = (
        (cos_laser > 0.05)
        & (pixels[:, 0] >= 0)
        & (pixels[:, 0] <= sensor.image_width_px - 1)
        & (pixels[:, 1] >= 0)
        & (pixels[:, 1] <= sensor.image_height_px - 1)
    )
    scatter = np.full(z.size, scatter_mm) / np.maximum(cos_laser, 0.3)
    widths = _image_widths(points, normals, pixels, plane_normal, sensor, scatter)
    keep = np.flatnonzero(visible)
    return StripeSamples(
        pixels=pixels[keep],
        width_px=widths[keep],
        irradiance=np.clip(cos_laser[keep], 0.0, 1.0),
        outline_index=np.full(keep.size, -1, np.int64),
        run_id=_runs(visible)[keep],
        points_track_mm=points[keep],
    )
