"""Reference rails (60E1, 54E1) built from their geometric definition, placed on a track.

A rail head is arcs and tangents (`data/rails.json`, provenance in `data/PROVENANCE.md`):
a crown arc, further arcs each tangent to the last, the last tangent to the inclined side.
`track_rails` inclines both rails towards the track centre (1:40 by default, 1:20 by site
configuration) and places them at the gauge, measured between the gauge faces 14 mm below
the running surface (EN 13848-1), in the station's track frame (X along the axle, positive
towards the right rail, Z up, Z = 0 at the top of the rails).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from importlib import resources

import numpy as np

from pipeline.imaging import GEOMETRY_FLOAT

RAIL_PROFILES = ("60E1", "54E1")
NOMINAL_GAUGE_MM = 1435.0
GAUGE_DEPTH_MM = 14.0
"""The gauge is measured between the gauge faces 14 mm below the running surface."""
RAIL_STEP_MM = 0.05
"""Arc-length spacing of the built rail profile: with the parabolic refinement of the contact
search, 0.02 mm moves λₑ by < 1e-4 on worn simulated wheels and takes 2.2× as long."""
INCLINATIONS = {"1:40": 1 / 40, "1:20": 1 / 20}


@dataclass(frozen=True, slots=True, eq=False)
class RailProfile:
    """A rail head in its own frame: u across the head, v up, crown top at (0, 0) [mm].

    Attributes
    ----------
    name : str
    u_mm, v_mm : ndarray of shape (K,), float64
        From the bottom of the u < 0 side, over the crown, down the u > 0 side [mm].
    """

    name: str
    u_mm: np.ndarray
    v_mm: np.ndarray

    def __post_init__(self) -> None:
        self.u_mm.flags.writeable = False
        self.v_mm.flags.writeable = False


@dataclass(frozen=True, slots=True, eq=False)
class TrackRails:
    """Both rails in the track frame, each as a graph Z(X) sorted by X [mm].

    Attributes
    ----------
    left_x_mm, left_z_mm, right_x_mm, right_z_mm : ndarray of shape (K,), float64
    rail : str
    inclination : str
    gauge_mm : float
    """

    left_x_mm: np.ndarray
    left_z_mm: np.ndarray
    right_x_mm: np.ndarray
    right_z_mm: np.ndarray
    rail: str
    inclination: str
    gauge_mm: float

    def __post_init__(self) -> None:
        for array in (self.left_x_mm, self.left_z_mm, self.right_x_mm, self.right_z_mm):
            array.flags.writeable = False


def _arc(centre: np.ndarray, radius: float, start: float, end: float) -> np.ndarray:
    """Points centre + radius·(sin a, cos a) for a from start to end (a = 0 straight up)."""
    count = max(2, int(math.ceil(radius * abs(end - start) / RAIL_STEP_MM)) + 1)
    angles = np.linspace(start, end, count)
    return centre + radius * np.column_stack([np.sin(angles), np.cos(angles)])


def _direction(angle: float) -> np.ndarray:
    return np.array([math.sin(angle), math.cos(angle)])


def _half_head(radii, crown_half_mm: float, half_mm: float, side: float, depth_mm: float):
    """The u ≥ 0 half of a head: crown arc, middle arc, last arc, inclined side line.

    Tangent arcs share the normal at their joint, so each centre lies on the previous
    radius through the joint. The middle arc's end angle is the one unknown: it is solved
    so that the last arc ends, tangent to the side line, at u = half_mm.
    """
    first, middle, last = radii
    end = math.atan2(1.0, side)  # the side line's outward normal, from straight up
    crown_end = math.asin(crown_half_mm / first)
    crown_centre = np.array([0.0, -first])
    middle_centre = crown_centre + (first - middle) * _direction(crown_end)

    def last_centre(angle: float) -> np.ndarray:
        return middle_centre + (middle - last) * _direction(angle)

    low, high = crown_end, end
    for _ in range(100):  # bisection: the last arc's end moves out as the middle arc grows
        mid = 0.5 * (low + high)
        if last_centre(mid)[0] + last * math.sin(end) < half_mm:
            low = mid
        else:
            high = mid
    middle_end = 0.5 * (low + high)
    pieces = [
        _arc(crown_centre, first, 0.0, crown_end),
        _arc(middle_centre, middle, crown_end, middle_end),
        _arc(last_centre(middle_end), last, middle_end, end),
    ]
    u0, v0 = pieces[-1][-1]
    v = np.linspace(v0, -depth_mm, max(2, int(math.ceil((v0 + depth_mm) / RAIL_STEP_MM)) + 1))
    pieces.append(np.column_stack([u0 + side * (v0 - v), v]))
    return np.concatenate(pieces)


def load_rail_profile(name: str) -> RailProfile:
    """Rail head `name` ("60E1" or "54E1") built from its definition in the package data.

    Raises
    ------
    ValueError
        If `name` is not a known rail.

    Examples
    --------
    >>> rail = load_rail_profile("60E1")
    >>> round(float(rail.u_mm.max() - rail.u_mm.min()), 1)  # head width at 40 mm depth
    76.0
    """
    if name not in RAIL_PROFILES:
        raise ValueError(f"rail must be one of {', '.join(RAIL_PROFILES)}, got {name!r}")
    text = resources.files("pipeline.profile").joinpath("data", "rails.json").read_text("utf-8")
    d = json.loads(text)[name]
    half = _half_head(
        d["radii_mm"],
        d["crown_half_width_mm"],
        d["head_half_width_mm"],
        d["side_inclination"],
        d["side_depth_mm"],
    )
    mirrored = half[::-1] * np.array([-1.0, 1.0])
    points = np.concatenate([mirrored[:-1], half])
    keep = np.concatenate([[True], np.any(np.diff(points, axis=0) != 0, axis=1)])
    points = np.ascontiguousarray(points[keep], dtype=GEOMETRY_FLOAT)
    return RailProfile(name, points[:, 0].copy(), points[:, 1].copy())


def track_rails(
    rail: str = "60E1", *, inclination: str = "1:40", gauge_mm: float = NOMINAL_GAUGE_MM
) -> TrackRails:
    """Both rails of a straight, level track in the track frame.

    Parameters
    ----------
    rail : str
        "60E1" (default) or "54E1".
    inclination : str
        Rail inclination towards the track centre, "1:40" (default) or "1:20".
    gauge_mm : float
        Track gauge [mm], 1400–1470.

    Returns
    -------
    TrackRails
    """
    if inclination not in INCLINATIONS:
        raise ValueError(
            f"inclination must be one of {', '.join(INCLINATIONS)}, got {inclination!r}"
        )
    if not (np.isfinite(gauge_mm) and 1400 <= gauge_mm <= 1470):
        raise ValueError(f"gauge_mm must be in [1400, 1470], got {gauge_mm}")
    profile = load_rail_profile(rail)
    tilt = math.atan(INCLINATIONS[inclination])
    # Right rail: its gauge side (u < 0) faces the centre and tilts down.
    u = profile.u_mm * math.cos(tilt) - profile.v_mm * math.sin(tilt)
    v = profile.u_mm * math.sin(tilt) + profile.v_mm * math.cos(tilt)
    v = v - v.max()
    gauge_u = float(u[v >= -GAUGE_DEPTH_MM].min())
    x = gauge_mm / 2 + (u - gauge_u)
    order = np.argsort(x, kind="stable")
    x, z = x[order], v[order]
    unique = np.concatenate([[True], np.diff(x) > 0])
    x, z = x[unique], z[unique]
    return TrackRails(-x[::-1].copy(), z[::-1].copy(), x, z, rail, inclination, float(gauge_mm))
