"""Station calibration `wheelscan-calibration/1`: dataclasses, validation, reading and writing.

One entry per sensor (`left_inner`, `left_outer`, `right_inner`, `right_outer`): the camera
intrinsics and distortion (OpenCV model), the laser plane in the camera frame and the
camera-to-track transform. The image size and bit depth the sensor delivers are part of the
calibration, so frames can be checked against it before anything is measured.

The format: docs/formats.md, "Calibration"; the frames: docs/coordinate-frames.md.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pipeline.errors import CalibrationError
from pipeline.imaging import GEOMETRY_FLOAT

CALIBRATION_FORMAT = "wheelscan-calibration/1"
SENSOR_NAMES = ("left_inner", "left_outer", "right_inner", "right_outer")
"""The four sensors of a station, `<side>_<position>`."""
BIT_DEPTHS = (8, 16)
MAX_CALIBRATION_BYTES = 1_000_000
MAX_FRAME_PIXELS = 2**25
"""Pixels of a frame at most (33.5 Mpx: 64 MiB decoded at 16 bit), so no calibration can
ask the service to decode more; OpenCV's own limit is 2^30."""
MIN_PLANE_DISTANCE_MM = 1.0
"""Smallest |d| of a laser plane: a plane through the camera centre (d = 0) holds every
ray it meets, so no stripe point can be triangulated from it."""
"""A calibration file is a few kB; anything larger is not one."""


def _readonly(array: np.ndarray) -> np.ndarray:
    array = np.array(array, dtype=GEOMETRY_FLOAT)
    array.flags.writeable = False
    return array


@dataclass(frozen=True, slots=True, eq=False)
class LaserPlane:
    """Laser light plane n·P = d in a camera frame.

    Attributes
    ----------
    normal : ndarray of shape (3,), float64
        Unit normal.
    d_mm : float
        Signed distance of the plane from the camera centre [mm].
    """

    normal: np.ndarray
    d_mm: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "normal", _readonly(self.normal))


@dataclass(frozen=True, slots=True, eq=False)
class SensorCalibration:
    """Calibration of one laser/camera sensor.

    Attributes
    ----------
    name : str
        Sensor name, one of `SENSOR_NAMES`.
    image_width_px, image_height_px : int
        Frame size the camera delivers [px].
    bit_depth : int
        8 or 16 (frames are uint8 or uint16).
    camera_matrix : ndarray of shape (3, 3), float64
        Intrinsics [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] [px].
    dist_coeffs : ndarray of shape (5,), float64
        OpenCV distortion coefficients k1, k2, p1, p2, k3.
    laser_plane : LaserPlane
        The laser plane in the camera frame [mm].
    T_track_camera : ndarray of shape (4, 4), float64
        Maps camera-frame points into the station's track frame [mm].
    reprojection_rms_px : float or None
        RMS reprojection error of the intrinsic calibration, when known [px].
    plane_rms_mm : float or None
        RMS distance of the stripe points from the fitted laser plane, when known [mm].
    """

    name: str
    image_width_px: int
    image_height_px: int
    bit_depth: int
    camera_matrix: np.ndarray
    dist_coeffs: np.ndarray
    laser_plane: LaserPlane
    T_track_camera: np.ndarray
    reprojection_rms_px: float | None = None
    plane_rms_mm: float | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "camera_matrix", _readonly(self.camera_matrix))
        object.__setattr__(self, "dist_coeffs", _readonly(self.dist_coeffs))
        object.__setattr__(self, "T_track_camera", _readonly(self.T_track_camera))

    @property
    def frame_dtype(self) -> np.dtype:
        """The frame dtype the sensor delivers (uint8 or uint16)."""
        return np.dtype(np.uint8 if self.bit_depth == 8 else np.uint16)


@dataclass(frozen=True, slots=True, eq=False)
class StationCalibration:
    """Calibration of a station: its sensors in `SENSOR_NAMES` order.

    Attributes
    ----------
    sensors : tuple of SensorCalibration
        One per calibrated sensor, unique names, ordered as in `SENSOR_NAMES`.
    """

    sensors: tuple[SensorCalibration, ...]

    def sensor(self, name: str) -> SensorCalibration:
        """Return the calibration of sensor `name`; CalibrationError when it has none."""
        for sensor in self.sensors:
            if sensor.name == name:
                return sensor
        raise CalibrationError(f"the calibration has no sensor {name!r}")

    @property
    def sensor_names(self) -> tuple[str, ...]:
        """Names of the calibrated sensors."""
        return tuple(sensor.name for sensor in self.sensors)


def _matrix(value: object, shape: tuple[int, ...], where: str) -> np.ndarray:
    try:
        array = np.array(value, dtype=GEOMETRY_FLOAT)
    except (TypeError, ValueError):
        raise CalibrationError(f"{where} must be numbers of shape {shape}") from None
    if array.shape != shape:
        raise CalibrationError(f"{where} must have shape {shape}, got {array.shape}")
    if not np.all(np.isfinite(array)):
        raise CalibrationError(f"{where} holds NaN or infinite values")
    return array


def _number(value: object, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise CalibrationError(f"{where} must be a finite number, got {value!r}")
    return float(value)


def _check_camera_matrix(matrix: np.ndarray, where: str) -> None:
    fx, fy = matrix[0, 0], matrix[1, 1]
    if fx <= 0 or fy <= 0:
        raise CalibrationError(f"{where}: focal lengths must be > 0, got fx={fx}, fy={fy}")
    if not np.allclose(matrix[2], [0.0, 0.0, 1.0]) or matrix[1, 0] != 0 or matrix[0, 1] != 0:
        raise CalibrationError(f"{where} must be [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]")


def _check_rigid(transform: np.ndarray, where: str) -> None:
    rotation = transform[:3, :3]
    if not np.allclose(transform[3], [0.0, 0.0, 0.0, 1.0]):
        raise CalibrationError(f"{where}: last row must be [0, 0, 0, 1]")
    if not np.allclose(rotation @ rotation.T, np.eye(3), atol=1e-6):
        raise CalibrationError(f"{where}: rotation part is not orthonormal")
    if np.linalg.det(rotation) <= 0:
        raise CalibrationError(f"{where}: rotation part is a reflection (det ≤ 0)")


def _parse_size(entry: dict, where: str) -> tuple[int, int, int]:
    size = entry.get("image_size")
    if (
        not isinstance(size, list)
        or len(size) != 2
        or not all(isinstance(v, int) and not isinstance(v, bool) and v > 0 for v in size)
    ):
        raise CalibrationError(f"{where}.image_size must be [width, height] in px, got {size!r}")
    if size[0] * size[1] > MAX_FRAME_PIXELS:
        raise CalibrationError(
            f"{where}.image_size {size[0]}x{size[1]} px exceeds {MAX_FRAME_PIXELS} pixels"
        )
    depth = entry.get("bit_depth")
    if depth not in BIT_DEPTHS or isinstance(depth, bool):
        raise CalibrationError(f"{where}.bit_depth must be 8 or 16, got {depth!r}")
    return size[0], size[1], int(depth)


def _parse_plane(value: object, where: str) -> LaserPlane:
    if not isinstance(value, dict) or set(value) != {"normal", "d"}:
        raise CalibrationError(f"{where} must be {{'normal': [nx, ny, nz], 'd': d}}")
    normal = _matrix(value["normal"], (3,), f"{where}.normal")
    if abs(np.linalg.norm(normal) - 1.0) > 1e-6:
        raise CalibrationError(f"{where}.normal must be a unit vector, got {normal.tolist()}")
    d_mm = _number(value["d"], f"{where}.d")
    if abs(d_mm) < MIN_PLANE_DISTANCE_MM:
        raise CalibrationError(
            f"{where}.d must be at least {MIN_PLANE_DISTANCE_MM} mm from 0 (a plane through "
            f"the camera centre cannot be triangulated), got {d_mm}"
        )
    return LaserPlane(normal=normal, d_mm=d_mm)


def _optional_residual(entry: dict, key: str, where: str) -> float | None:
    residuals = entry.get("residuals", {})
    if not isinstance(residuals, dict):
        raise CalibrationError(f"{where}.residuals must be an object")
    if residuals.get(key) is None:
        return None
    value = _number(residuals[key], f"{where}.residuals.{key}")
    if value < 0:
        raise CalibrationError(f"{where}.residuals.{key} must be ≥ 0, got {value}")
    return value


def _parse_sensor(name: str, entry: object) -> SensorCalibration:
    where = f"sensors.{name}"
    if not isinstance(entry, dict):
        raise CalibrationError(f"{where} must be an object")
    for key in ("image_size", "bit_depth", "camera_matrix", "dist_coeffs", "laser_plane"):
        if key not in entry:
            raise CalibrationError(f"{where} lacks {key!r}")
    if "camera_to_track" not in entry:
        raise CalibrationError(f"{where} lacks 'camera_to_track'")
    width, height, depth = _parse_size(entry, where)
    matrix = _matrix(entry["camera_matrix"], (3, 3), f"{where}.camera_matrix")
    _check_camera_matrix(matrix, f"{where}.camera_matrix")
    transform = _matrix(entry["camera_to_track"], (4, 4), f"{where}.camera_to_track")
    _check_rigid(transform, f"{where}.camera_to_track")
    return SensorCalibration(
        name=name,
        image_width_px=width,
        image_height_px=height,
        bit_depth=depth,
        camera_matrix=matrix,
        dist_coeffs=_matrix(entry["dist_coeffs"], (5,), f"{where}.dist_coeffs"),
        laser_plane=_parse_plane(entry["laser_plane"], f"{where}.laser_plane"),
        T_track_camera=transform,
        reprojection_rms_px=_optional_residual(entry, "reprojection_rms_px", where),
        plane_rms_mm=_optional_residual(entry, "plane_rms_mm", where),
    )


def parse_calibration(document: object) -> StationCalibration:
    """Validate a parsed `wheelscan-calibration/1` JSON document.

    Parameters
    ----------
    document : object
        The parsed JSON (a dict with "format" and "sensors").

    Returns
    -------
    StationCalibration

    Raises
    ------
    CalibrationError
        With one message naming the first fault: wrong format, unknown or missing sensor,
        a field of the wrong shape, a non-unit plane normal, a non-rigid transform.
    """
    if not isinstance(document, dict):
        raise CalibrationError("calibration must be a JSON object")
    if document.get("format") != CALIBRATION_FORMAT:
        raise CalibrationError(
            f"calibration format must be {CALIBRATION_FORMAT!r}, got {document.get('format')!r}"
        )
    sensors = document.get("sensors")
    if not isinstance(sensors, dict) or not sensors:
        raise CalibrationError("calibration 'sensors' must be a non-empty object")
    unknown = sorted(set(sensors) - set(SENSOR_NAMES))
    if unknown:
        raise CalibrationError(
            f"calibration has unknown sensor {unknown[0]!r}; sensors are {', '.join(SENSOR_NAMES)}"
        )
    return StationCalibration(
        sensors=tuple(_parse_sensor(n, sensors[n]) for n in SENSOR_NAMES if n in sensors)
    )


def load_calibration_json(text: str | bytes) -> StationCalibration:
    """Parse and validate calibration JSON text; CalibrationError when it is not valid."""
    if len(text) > MAX_CALIBRATION_BYTES:
        raise CalibrationError(f"calibration is larger than {MAX_CALIBRATION_BYTES} bytes")
    try:
        document = json.loads(text)
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise CalibrationError(f"calibration is not valid JSON: {exc}") from None
    return parse_calibration(document)


def read_calibration(path: str | Path) -> StationCalibration:
    """Read and validate a `wheelscan-calibration/1` file.

    Raises
    ------
    CalibrationError
        When the file is missing, unreadable or not a valid calibration.
    """
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise CalibrationError(f"cannot read calibration {path}: {exc.strerror}") from None
    try:
        return load_calibration_json(data)
    except CalibrationError as exc:
        raise CalibrationError(f"{path}: {exc}") from None


def calibration_to_document(calibration: StationCalibration) -> dict:
    """The JSON document (plain dicts and lists) of a calibration."""
    sensors = {}
    for s in calibration.sensors:
        residuals = {
            "reprojection_rms_px": s.reprojection_rms_px,
            "plane_rms_mm": s.plane_rms_mm,
        }
        sensors[s.name] = {
            "image_size": [s.image_width_px, s.image_height_px],
            "bit_depth": s.bit_depth,
            "camera_matrix": s.camera_matrix.tolist(),
            "dist_coeffs": s.dist_coeffs.tolist(),
            "laser_plane": {"normal": s.laser_plane.normal.tolist(), "d": s.laser_plane.d_mm},
            "camera_to_track": s.T_track_camera.tolist(),
            "residuals": {k: v for k, v in residuals.items() if v is not None},
        }
    return {"format": CALIBRATION_FORMAT, "sensors": sensors}


def write_calibration(calibration: StationCalibration, path: str | Path) -> None:
    """Write a calibration as `wheelscan-calibration/1` JSON (full float precision)."""
    text = json.dumps(calibration_to_document(calibration), indent=2)
    Path(path).write_text(text + "\n", encoding="utf-8")
