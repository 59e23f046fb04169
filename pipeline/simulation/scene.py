"""The station lit by daylight, as a camera sees it through its 405 nm bandpass filter.

The filter passes a few nanometres of the ambient light, so the scene is dim but not black:
the wheel's rim and web, the rail head and the axle-box face beside the wheel show at grey
15–90 (8-bit scale) with rust and wear grain, and the polished or machined corners (the
rail's gauge corner, the rim's chamfer) catch the light as thin bright lines; behind
everything the bogie's underside and the ballast are dimmer still. Surfaces are quad meshes
of track-frame points drawn far to near (painter's order) with Lambertian sky and ground
light; the corners are drawn where the depth buffer shows them. Reflectance grain is an
image-space random field: a new patch of the wheel faces the camera on every pass.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from pipeline.calibration.geometry import camera_centre_track, project_track_points
from pipeline.calibration.model import SensorCalibration
from pipeline.imaging import GEOMETRY_FLOAT, IMAGE_FLOAT
from pipeline.simulation.render import WheelPose
from pipeline.simulation.wheel import WheelProfile, outward_normals

SCENE_GREY_DN = (15.0, 90.0)
"""Grey range (8-bit scale) of lit surfaces through the bandpass filter: a black surface in
shadow reads 15, a bright one facing the sky 90."""
EDGE_GREY_DN = (95.0, 170.0)
"""Peak grey of the bright corners (polished gauge corner, machined chamfer)."""
EDGE_WIDTH_PX = (1.0, 2.5)
"""Drawn width of a bright corner before the 0.8 px lens blur [px]."""
BACKGROUND_GREY_DN = (8.0, 20.0)
"""Grey of what lies behind the parts (bogie underside, ballast): dim, in broad patches."""
BACKGROUND_CORRELATION_PX = 120.0
GRAIN_CORRELATION_PX = (2.0, 20.0)
GRAIN_CONTRAST = 0.35
"""Rust and wear grain: a log-normal reflectance field, std/mean 0.35, correlated over
2–20 px (a new length per frame)."""
SKY_WEIGHT, GROUND_WEIGHT, AMBIENT_WEIGHT = 0.75, 0.35, 0.25
"""Lambertian light from the sky (above), from the ballast (below) and scattered all round."""
GAUGE_HALF_MM = 717.5
"""Half the track gauge: the rail's gauge face 14 mm below its top is at |X| = 717.5 mm."""
RAIL_HEAD_WIDTH_MM = 72.0
RAIL_CORNER_RADIUS_MM = 13.0
RAIL_HEAD_DEPTH_MM = 38.0
"""UIC 60-like rail head: 72 mm wide, 13 mm gauge-corner radius, sides 38 mm deep."""
RAIL_Y_MM = ((-300.0, -50.0), (50.0, 500.0))
"""The rail head is drawn along these stretches of Y [mm]: the laser planes shine through a
100 mm measuring gap in the rail head, so it neither hides the stripe nor carries one."""
WHEEL_ARC_RAD = 0.45
"""The wheel is drawn over ±0.45 rad (±185 mm of rim) about its lowest section."""
WEB_DEPTH_MM = 150.0
"""The web's faces are drawn this far inwards of the rim's faces."""
MESH_STEP_MM = 2.0
"""Quad size of the meshes [mm] (≈ 15 px at the wheel); grain adds the fine detail."""


@dataclass(frozen=True, slots=True, eq=False)
class SceneSurface:
    """A quad mesh in the track frame.

    Attributes
    ----------
    points_track_mm, normals : ndarray of shape (I, J, 3), float64
        Mesh nodes [mm] and unit outward normals.
    albedo : float
        Diffuse reflectance through the filter (0..1).
    """

    points_track_mm: np.ndarray
    normals: np.ndarray
    albedo: float


def _revolve(x_mm, z_mm, pose: WheelPose, arc_rad: float) -> tuple[np.ndarray, np.ndarray]:
    """Outline (x, z) of the profile frame swept about the axle: nodes and normals (I, J, 3)."""
    a = np.asarray(pose.axle_direction, GEOMETRY_FLOAT)
    centre = np.asarray(pose.centre_track_mm, GEOMETRY_FLOAT)
    e1, e2 = np.array([-a[1], a[0], 0.0]), np.array([0.0, 0.0, 1.0])
    steps = max(int(2 * arc_rad * pose.radius_mm / MESH_STEP_MM), 2)
    phi = -np.pi / 2 + np.linspace(-arc_rad, arc_rad, steps)
    radial = np.cos(phi)[None, :, None] * e1 + np.sin(phi)[None, :, None] * e2
    u = pose.side_sign * (pose.back_face_axial_mm + x_mm)
    r = pose.radius_mm + z_mm
    points = centre + u[:, None, None] * a + r[:, None, None] * radial
    n2 = outward_normals(x_mm, z_mm)
    normals = pose.side_sign * n2[:, None, :1] * a + n2[:, None, 1:] * radial
    return points, normals


def wheel_surfaces(profile: WheelProfile, pose: WheelPose) -> list[SceneSurface]:
    """The rim (tread, flange, faces) and the web's two faces of a wheel."""
    x, z = profile.x_mm, profile.z_mm
    stride = max(int(MESH_STEP_MM / np.median(np.hypot(np.diff(x), np.diff(z)))), 1)
    rim = _revolve(x[::stride], z[::stride], pose, WHEEL_ARC_RAD)
    depth = np.linspace(z.min() - WEB_DEPTH_MM, z.min(), 20)
    back = _revolve(np.zeros(depth.size), depth, pose, WHEEL_ARC_RAD)
    field = _revolve(np.full(depth.size, x.max()), depth[::-1], pose, WHEEL_ARC_RAD)
    return [SceneSurface(*rim, 0.55), SceneSurface(*back, 0.35), SceneSurface(*field, 0.35)]


def rail_head_outline(side_sign: int) -> tuple[np.ndarray, np.ndarray]:
    """Rail head cross-section (X, Z) [mm] from the gauge face round to the field face."""
    r = RAIL_CORNER_RADIUS_MM
    angles = np.linspace(np.pi, np.pi / 2, 8)
    g = np.concatenate(
        [[0.0, 0.0], r + r * np.cos(angles), [RAIL_HEAD_WIDTH_MM - r], [RAIL_HEAD_WIDTH_MM] * 2]
    )
    h = np.concatenate(
        [[-RAIL_HEAD_DEPTH_MM, -r], -r + r * np.sin(angles), [0.0], [-r, -RAIL_HEAD_DEPTH_MM]]
    )
    return side_sign * (GAUGE_HALF_MM + g), h


def rail_surfaces(side_sign: int) -> list[SceneSurface]:
    """The rail head of one side, along Y over the stretches `RAIL_Y_MM`."""
    x, z = rail_head_outline(side_sign)
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(x), np.diff(z)))])
    at = np.linspace(0.0, arc[-1], int(arc[-1] / MESH_STEP_MM) + 1)
    x, z = np.interp(at, arc, x), np.interp(at, arc, z)
    n2 = outward_normals(side_sign * x, z) * [side_sign, 1.0]
    surfaces = []
    for start, end in RAIL_Y_MM:
        y = np.linspace(start, end, int((end - start) / (2 * MESH_STEP_MM)) + 1)
        points = np.stack(np.broadcast_arrays(x[:, None], y[None, :], z[:, None]), axis=-1)
        normals = np.zeros(points.shape)
        normals[..., 0] = n2[:, None, 0]
        normals[..., 2] = n2[:, None, 1]
        surfaces.append(SceneSurface(points.astype(GEOMETRY_FLOAT), normals, 0.4))
    return surfaces


def plate_surface(plate_x_mm: float, z_range_mm: tuple[float, float], facing: float):
    """A flat vertical face X = plate_x (axle box, brake hanger) facing ±X."""
    y = np.linspace(-160.0, 160.0, 40)
    z = np.linspace(z_range_mm[0], z_range_mm[1], 12)
    yy, zz = np.meshgrid(y, z, indexing="ij")
    points = np.stack([np.full(yy.shape, plate_x_mm), yy, zz], axis=-1)
    normals = np.zeros(points.shape)
    normals[..., 0] = facing
    return SceneSurface(points, normals, 0.3)


def _shade(normals: np.ndarray, sky: np.ndarray) -> np.ndarray:
    up = normals[..., 2]
    return (
        AMBIENT_WEIGHT
        + SKY_WEIGHT * np.clip(normals @ sky, 0, None)
        + GROUND_WEIGHT * np.clip(-up, 0, None)
    )


def render_scene(
    surfaces: list[SceneSurface],
    sensor: SensorCalibration,
    sky_direction: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Shade × albedo (0..1) and distance to the camera [mm] (inf: nothing) per pixel.

    Quads facing away from the camera are culled; the rest are drawn far to near.
    """
    shape = (sensor.image_height_px, sensor.image_width_px)
    shade = np.zeros(shape, IMAGE_FLOAT)
    distance = np.full(shape, np.inf, IMAGE_FLOAT)
    camera = camera_centre_track(sensor)
    quads, values, depths = [], [], []
    for surface in surfaces:
        p, n = surface.points_track_mm, surface.normals
        mid = 0.25 * (p[:-1, :-1] + p[1:, :-1] + p[:-1, 1:] + p[1:, 1:])
        mid_n = 0.25 * (n[:-1, :-1] + n[1:, :-1] + n[:-1, 1:] + n[1:, 1:])
        to_camera = camera - mid
        depth = np.linalg.norm(to_camera, axis=-1)
        facing = np.einsum("ijk,ijk->ij", mid_n, to_camera) > 0
        pixels = project_track_points(p.reshape(-1, 3), sensor).reshape(*p.shape[:2], 2)
        corners = np.stack([pixels[:-1, :-1], pixels[1:, :-1], pixels[1:, 1:], pixels[:-1, 1:]])
        low, high = corners.min(axis=0), corners.max(axis=0)
        inside = (high > -2).all(-1) & (low < np.array(shape[::-1]) + 2).all(-1)
        keep = facing & inside
        i, j = np.nonzero(keep)
        quads.append(np.round(corners[:, i, j] * 16).astype(np.int32).transpose(1, 0, 2))
        values.append(surface.albedo * _shade(mid_n[i, j], sky_direction))
        depths.append(depth[i, j])
    order = np.argsort(-np.concatenate(depths), kind="stable")
    all_quads, all_values = np.concatenate(quads), np.concatenate(values)
    all_depths = np.concatenate(depths)
    for k in order:
        cv2.fillConvexPoly(shade, all_quads[k], float(all_values[k]), cv2.LINE_8, 4)
        cv2.fillConvexPoly(distance, all_quads[k], float(all_depths[k]), cv2.LINE_8, 4)
    return shade, distance


def grain(shape: tuple[int, int], correlation_px: float, contrast: float, rng) -> np.ndarray:
    """Log-normal reflectance field of mean 1, std/mean `contrast`, correlated over
    `correlation_px` (white noise on a grid that fine, cubic-interpolated) [px]."""
    step = max(correlation_px / 2.0, 1.0)
    coarse = rng.normal(0.0, 1.0, (int(shape[0] / step) + 4, int(shape[1] / step) + 4))
    field = cv2.resize(
        coarse.astype(IMAGE_FLOAT),
        (int(round(coarse.shape[1] * step)), int(round(coarse.shape[0] * step))),
        interpolation=cv2.INTER_CUBIC,
    )[: shape[0], : shape[1]]
    field = cv2.GaussianBlur(field, (0, 0), 0.5 * step)
    field /= max(float(field.std()), 1e-6)
    s = np.sqrt(np.log1p(contrast**2))
    return np.exp(s * field - 0.5 * s * s).astype(IMAGE_FLOAT)


def draw_edges(
    image: np.ndarray,
    curves_track_mm: list[np.ndarray],
    distance: np.ndarray,
    sensor: SensorCalibration,
    rng: np.random.Generator,
) -> None:
    """Add thin bright lines along 3-D curves where the depth buffer shows them, in place."""
    camera = camera_centre_track(sensor)
    layer = np.zeros(image.shape, IMAGE_FLOAT)
    height, width = image.shape
    for curve in curves_track_mm:
        pixels = project_track_points(curve, sensor)
        col, row = np.round(pixels[:, 0]).astype(int), np.round(pixels[:, 1]).astype(int)
        inside = (col >= 0) & (col < width) & (row >= 0) & (row < height)
        seen = np.zeros(curve.shape[0], bool)
        range_mm = np.linalg.norm(curve - camera, axis=1)
        seen[inside] = range_mm[inside] <= distance[row[inside], col[inside]] + 3.0
        thickness = int(round(rng.uniform(*EDGE_WIDTH_PX)))
        grey = rng.uniform(*EDGE_GREY_DN)
        breaks = np.flatnonzero(np.diff(seen.astype(np.int8))) + 1
        for run in np.split(np.arange(curve.shape[0]), breaks):
            if run.size > 1 and seen[run[0]]:
                pts = np.round(pixels[run] * 16).astype(np.int32)
                cv2.polylines(layer, [pts], False, grey, max(thickness, 1), cv2.LINE_AA, 4)
    image += cv2.GaussianBlur(layer, (0, 0), 0.8)


def scene_grey(shade: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Grey (8-bit scale) of the lit surfaces: `SCENE_GREY_DN` spanned by shade × grain."""
    correlation = rng.uniform(*GRAIN_CORRELATION_PX)
    texture = grain(shade.shape, correlation, GRAIN_CONTRAST, rng)
    low, high = SCENE_GREY_DN
    lit = shade > 0
    grey = rng.uniform(*BACKGROUND_GREY_DN) * grain(
        shade.shape, BACKGROUND_CORRELATION_PX, 0.3, rng
    )
    grey[lit] = low + (high - low) * np.clip(shade[lit] * texture[lit], 0.0, 1.0)
    return cv2.GaussianBlur(grey, (0, 0), 1.0)


def scene_edges(profile: WheelProfile, pose: WheelPose) -> list[np.ndarray]:
    """The bright corners as 3-D curves [mm]: the rim's chamfer (where the tread meets the
    field face) and the rail's gauge corner."""
    x, z = profile.x_mm, profile.z_mm
    chamfer = int(np.flatnonzero(x >= x.max())[0])
    curves = [_revolve(x[[chamfer] * 2], z[[chamfer] * 2] + [0.0, 0.1], pose, WHEEL_ARC_RAD)[0][0]]
    gx, gz = rail_head_outline(pose.side_sign)
    corner = len(gx) // 2 - 1  # the gauge corner arc's middle node (≈ 45°)
    for start, end in RAIL_Y_MM:
        y = np.arange(start, end, 1.0)
        curves.append(
            np.column_stack([np.full(y.size, gx[corner]), y, np.full(y.size, gz[corner])])
        )
    return curves
