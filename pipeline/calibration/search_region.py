"""Where a wheel's stripe can lie in a camera: what the station's calibration already knows.

The laser plane meets a wheel only inside the track window: the wheel's back face is half
a back-to-back from the track centre, the wheelset shifts laterally by its flangeway play,
and the rim's cross-section spans a known box of the profile frame (back face to beyond
the field face, a worn flange's tip to the rim's inner edge). That box, cut by the laser
plane and projected through the camera, bounds the stripe in the image; wayside systems
search and segment there first.
"""

from __future__ import annotations

import numpy as np

from pipeline.calibration.geometry import (
    apply_transform,
    invert_rigid,
    laser_plane_track,
    project_track_points,
)
from pipeline.calibration.model import SensorCalibration
from pipeline.imaging import PixelRegion

HALF_BACK_TO_BACK_MM = (1350.0 / 2, 1363.0 / 2)
"""Half back-to-back range: LM wheelsets 1353 ± 3 mm, EN (S1002) 1357–1363 mm."""
LATERAL_SHIFT_MM = 10.0
"""Wheelset offset from the track centre either way: the flangeway play on straight track
(≈ 7 mm a side) plus yaw at the measuring plane."""
PROFILE_X_MM = (-8.0, 150.0)
"""Profile-frame x from just outside the back face to beyond the field face (≈ 135–140)."""
PROFILE_Z_MM = (-45.0, 40.0)
"""Profile-frame z from the rim's inner edge (−40) to a worn flange's tip (< 36 + 4)."""
MARGIN_PX = 24
"""Added on every side: half the widest stripe (21 px) and the filters' reach."""
MIN_SIDE_PX = MARGIN_PX + 1
"""Fewer rows or columns than this inside the frame: the window itself misses the frame."""
MIN_DEPTH_MM = 1.0
"""Window points less than this in front of the camera (or behind it) cannot be imaged:
their projection through the distortion polynomial is meaningless (near the camera's
plane it overflows, > 1e19 px on a camera at the track origin)."""


def stripe_search_region(sensor: SensorCalibration, side: str) -> PixelRegion | None:
    """The part of the sensor's frame where a wheel's stripe can lie.

    Parameters
    ----------
    sensor : SensorCalibration
        A sensor of the wheel's side; its laser plane and camera.
    side : str
        "left" or "right": which rail the wheel runs on.

    Returns
    -------
    PixelRegion or None
        The bounding box of the projected window, widened by `MARGIN_PX` and clipped to
        the frame; None when less than `MIN_SIDE_PX` of it in either direction lies inside
        the frame (a calibration that does not see the window: the whole frame is searched,
        and the quality figures say so by a searched share of 1).

    Notes
    -----
    At the wheel's lowest section a profile point (x, z) sits at track X = s·(b/2 + x) + e
    and Z = −z (s = ±1 the side, b the back-to-back, e the lateral shift); the laser plane
    n·P = d fixes Y = (d − n_X·X − n_Z·Z)/n_Y. A 33 × 33 grid over the window is projected
    with the lens distortion, so the box holds the curved image of the window. Grid points
    less than `MIN_DEPTH_MM` in front of the camera are left out (none in front: None), and
    projections are clipped to the frame ± `MARGIN_PX` before the box is taken: the
    distortion polynomial far outside the field of view gives arbitrarily large pixels.
    """
    if side not in ("left", "right"):
        raise ValueError(f"side must be 'left' or 'right', got {side!r}")
    sign = 1.0 if side == "right" else -1.0
    reach = (
        HALF_BACK_TO_BACK_MM[0] + PROFILE_X_MM[0] - LATERAL_SHIFT_MM,
        HALF_BACK_TO_BACK_MM[1] + PROFILE_X_MM[1] + LATERAL_SHIFT_MM,
    )
    u, z = np.meshgrid(np.linspace(*reach, 33), np.linspace(*PROFILE_Z_MM, 33))
    normal, d = laser_plane_track(sensor)
    x_track, z_track = sign * u.ravel(), -z.ravel()
    y_track = (d - normal[0] * x_track - normal[2] * z_track) / normal[1]
    points = np.column_stack([x_track, y_track, z_track])
    depth = apply_transform(invert_rigid(sensor.T_track_camera), points)[:, 2]
    points = points[np.isfinite(depth) & (depth >= MIN_DEPTH_MM)]
    if points.shape[0] == 0:
        return None
    width, height = sensor.image_width_px, sensor.image_height_px
    pixels = project_track_points(points, sensor)
    pixels = np.clip(pixels, -MARGIN_PX, [width + MARGIN_PX, height + MARGIN_PX])
    low = np.floor(pixels.min(axis=0)).astype(int) - MARGIN_PX
    high = np.ceil(pixels.max(axis=0)).astype(int) + MARGIN_PX + 1
    row_start, row_stop = max(int(low[1]), 0), min(int(high[1]), height)
    col_start, col_stop = max(int(low[0]), 0), min(int(high[0]), width)
    if row_stop - row_start < MIN_SIDE_PX or col_stop - col_start < MIN_SIDE_PX:
        return None
    return PixelRegion(row_start, row_stop, col_start, col_stop)
