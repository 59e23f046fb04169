"""The simulated measuring station: four laser/camera sensors and their true calibration.

Optics follow the paper's station (Basler acA1600-60gm + Computar M1614-MP2): 1600×1200 px,
4.5 µm pixels, 16 mm lens (f = 3555.6 px), 405 nm line lasers projecting from both sides of
each rail. Track frame (docs/coordinate-frames.md): X along the axle towards the right rail,
Y along the rail, Z up, Z = 0 at the rail top. Each side has an inner sensor (gauge side:
back face and flange) and an outer sensor (field side: flange flank, tread and chamfer);
their views overlap on the flange. The light planes are nearly the vertical plane Y = 0
through the wheel's lowest section, each a little tilted and offset as real mountings are,
and each camera sits 380 mm along the rail from its plane for triangulation. Inner and outer
lasers are strobed alternately, so each frame shows its own sensor's laser only.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pipeline.calibration.geometry import rigid_transform
from pipeline.calibration.model import (
    SENSOR_NAMES,
    LaserPlane,
    SensorCalibration,
    StationCalibration,
)
from pipeline.imaging import GEOMETRY_FLOAT

IMAGE_WIDTH_PX = 1600
IMAGE_HEIGHT_PX = 1200
PIXEL_PITCH_MM = 0.0045
FOCAL_LENGTH_MM = 16.0
LASER_WAVELENGTH_NM = 405.0
NOMINAL_BACK_TO_BACK_MM = {"LMA": 1353.0, "S1002": 1360.0}
"""Nominal back-to-back per wheel profile on standard gauge [mm]: LM wheelsets 1353 ± 3,
EN (S1002) wheelsets 1360 (limits 1357–1363)."""
STATION_SEED = 20260405
"""Seed of the station's fixed mounting deviations (the 'true' calibration of the site)."""

# Right-side poses [mm]; the left side is the mirror image X → −X.
_CAMERA_POSITIONS = {"inner": (440.0, -380.0, -170.0), "outer": (1000.0, -380.0, -190.0)}
_CAMERA_TARGETS = {"inner": (700.0, 0.0, 5.0), "outer": (760.0, 0.0, -8.0)}
_LASER_ORIGINS = {"inner": (470.0, 0.0, -260.0), "outer": (1030.0, 0.0, -260.0)}


@dataclass(frozen=True, slots=True, eq=False)
class Station:
    """A simulated station: its true calibration and where the lasers sit.

    Attributes
    ----------
    calibration : StationCalibration
        The true calibration of all four sensors.
    laser_origins_track_mm : ndarray of shape (4, 3), float64
        Laser emitter positions in the track frame, in `SENSOR_NAMES` order [mm].
    """

    calibration: StationCalibration
    laser_origins_track_mm: np.ndarray

    def __post_init__(self) -> None:
        self.laser_origins_track_mm.flags.writeable = False

    def laser_origin(self, name: str) -> np.ndarray:
        """Laser position of sensor `name` in the track frame [mm]."""
        return self.laser_origins_track_mm[SENSOR_NAMES.index(name)]


def look_at(position_mm: np.ndarray, target_mm: np.ndarray) -> np.ndarray:
    """T_track_camera of a camera at `position` looking at `target`, image-up towards +Z.

    The camera frame is OpenCV's: z along the optical axis, x to the image right, y down.
    """
    forward = target_mm - position_mm
    forward = forward / np.linalg.norm(forward)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    down = np.cross(forward, right)
    return rigid_transform(np.column_stack([right, down, forward]), position_mm)


def _rotation(axis: np.ndarray, angle_rad: float) -> np.ndarray:
    axis = axis / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle_rad) * k + (1 - np.cos(angle_rad)) * k @ k


def _sensor(
    name: str, bit_depth: int, rng: np.random.Generator
) -> tuple[SensorCalibration, np.ndarray]:
    side, position = name.split("_")
    mirror = np.array([-1.0 if side == "left" else 1.0, 1.0, 1.0])
    camera_position = np.array(_CAMERA_POSITIONS[position]) * mirror + rng.normal(0, 2.0, 3)
    target = np.array(_CAMERA_TARGETS[position]) * mirror
    T_track_camera = look_at(camera_position, target)
    roll = _rotation(T_track_camera[:3, 2], rng.normal(0, 0.01))
    T_track_camera[:3, :3] = roll @ T_track_camera[:3, :3]
    focal_px = FOCAL_LENGTH_MM / PIXEL_PITCH_MM * (1 + rng.normal(0, 0.002))
    camera_matrix = np.array(
        [
            [focal_px, 0.0, (IMAGE_WIDTH_PX - 1) / 2 + rng.normal(0, 4.0)],
            [0.0, focal_px, (IMAGE_HEIGHT_PX - 1) / 2 + rng.normal(0, 4.0)],
            [0.0, 0.0, 1.0],
        ]
    )
    dist_coeffs = np.array(
        [
            -0.09 + rng.normal(0, 0.01),
            0.15 + rng.normal(0, 0.02),
            rng.normal(0, 2e-4),
            rng.normal(0, 2e-4),
            0.0,
        ]
    )
    tilt = _rotation(np.array([1.0, 0.0, 0.0]), rng.normal(0, 0.006))
    tilt = _rotation(np.array([0.0, 0.0, 1.0]), rng.normal(0, 0.006)) @ tilt
    normal_track = tilt @ np.array([0.0, 1.0, 0.0])
    laser_origin = np.array(_LASER_ORIGINS[position]) * mirror
    laser_origin[1] = rng.normal(0, 0.4)
    d_track = float(normal_track @ laser_origin)
    rotation, translation = T_track_camera[:3, :3], T_track_camera[:3, 3]
    plane = LaserPlane(rotation.T @ normal_track, d_track - float(normal_track @ translation))
    sensor = SensorCalibration(
        name=name,
        image_width_px=IMAGE_WIDTH_PX,
        image_height_px=IMAGE_HEIGHT_PX,
        bit_depth=bit_depth,
        camera_matrix=camera_matrix,
        dist_coeffs=dist_coeffs,
        laser_plane=plane,
        T_track_camera=T_track_camera,
    )
    return sensor, laser_origin


def build_station(*, bit_depth: int = 8, seed: int = STATION_SEED) -> Station:
    """The simulated station with its fixed (seeded) mounting deviations.

    Parameters
    ----------
    bit_depth : int
        8 or 16: the frames the cameras deliver.
    seed : int
        Seed of the mounting deviations; the same seed gives the same station.

    Returns
    -------
    Station
    """
    if bit_depth not in (8, 16):
        raise ValueError(f"bit_depth must be 8 or 16, got {bit_depth}")
    rng = np.random.default_rng(seed)
    sensors, origins = zip(*(_sensor(name, bit_depth, rng) for name in SENSOR_NAMES), strict=True)
    return Station(
        calibration=StationCalibration(sensors=tuple(sensors)),
        laser_origins_track_mm=np.array(origins, dtype=GEOMETRY_FLOAT),
    )
