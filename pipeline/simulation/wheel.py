"""Wheel model: a surface of revolution of a profile (reference or worn) on an axle.

A `WheelProfile` is the closed outline of the rim cross-section in the profile frame: up the
back face, along the published profile (flange, tread, chamfer) and down the field-side
face, densely resampled by arc length. Wear is applied as smooth displacements of that
outline (flange height change, flank wear that thins the flange, a hollow tread), after
which z is re-zeroed at the reference point x = 70 mm; the true parameters are read off the
final outline, so they are exact for the simulated wheel.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pipeline.imaging import GEOMETRY_FLOAT
from pipeline.profile.flange import FlangeParameters, curve_flange_parameters
from pipeline.profile.reference import ReferenceProfile

REFERENCE_X_MM = 70.0
FACE_DEPTH_MM = 40.0
"""How far the back and field-side faces reach below z = 0 (the rim's inner edge) [mm]."""
OUTLINE_STEP_MM = 0.05
"""Arc-length spacing of the outline: ≤ 0.5 px in the images, far finer than the stripe."""
BACK_ARCS = {"S1002": (20.5, 9.519259)}
"""Centre (x, z) of the back-of-flange arc that reaches the back face vertically, for tables
that stop short of x = 0 (S1002: section H, R20.5, centre x_src −49.5 → x 20.5)."""


@dataclass(frozen=True, slots=True, eq=False)
class WheelProfile:
    """Rim cross-section outline in the profile frame.

    Attributes
    ----------
    name : str
    x_mm, z_mm : ndarray of shape (K,), float64
        Outline from the bottom of the back face, over the flange and tread, down the
        field-side face, at `OUTLINE_STEP_MM` spacing [mm].
    truth : FlangeParameters
        The exact parameters of this outline.
    """

    name: str
    x_mm: np.ndarray
    z_mm: np.ndarray
    truth: FlangeParameters

    def __post_init__(self) -> None:
        self.x_mm.flags.writeable = False
        self.z_mm.flags.writeable = False


@dataclass(frozen=True, slots=True)
class Wear:
    """Wear of one wheel [mm].

    Attributes
    ----------
    flange_height_change_mm : float
        Added to the flange (above z = 2 mm, full above 22 mm).
    flange_thinning_mm : float
        Flank wear: the flank side of the flange moves towards the back face.
    hollow_depth_mm : float
        Depth of a hollow worn into the tread around x = 75 mm.
    """

    flange_height_change_mm: float = 0.0
    flange_thinning_mm: float = 0.0
    hollow_depth_mm: float = 0.0


def _smoothstep(t: np.ndarray) -> np.ndarray:
    t = np.clip(t, 0.0, 1.0)
    return t * t * (3 - 2 * t)


def _resample(x: np.ndarray, z: np.ndarray, step_mm: float) -> tuple[np.ndarray, np.ndarray]:
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(x), np.diff(z)))])
    at = np.linspace(0.0, arc[-1], int(np.ceil(arc[-1] / step_mm)) + 1)
    return np.interp(at, arc, x), np.interp(at, arc, z)


def _outline(reference: ReferenceProfile) -> tuple[np.ndarray, np.ndarray]:
    x, z = reference.x_mm, reference.z_mm
    head_x, head_z = [0.0, 0.0], [-FACE_DEPTH_MM, z[0]]
    if reference.name in BACK_ARCS and x[0] > 0:
        cx, cz = BACK_ARCS[reference.name]
        radius = cx
        end = np.arctan2(z[0] - cz, x[0] - cx)
        angles = np.linspace(np.pi, end, 50)[:-1]
        head_x = [0.0, *(cx + radius * np.cos(angles))]
        head_z = [-FACE_DEPTH_MM, *(cz + radius * np.sin(angles))]
    tail_x, tail_z = [x[-1]], [-FACE_DEPTH_MM]
    outline_x = np.concatenate([head_x, x, tail_x])
    outline_z = np.concatenate([head_z, z, tail_z])
    return _resample(outline_x, outline_z, OUTLINE_STEP_MM)


def _apply_wear(x: np.ndarray, z: np.ndarray, wear: Wear) -> tuple[np.ndarray, np.ndarray]:
    x, z = x.copy(), z.copy()
    top = int(np.argmax(z))
    x_top = x[top]
    flange = x < x_top + 30.0
    z[flange] += wear.flange_height_change_mm * _smoothstep((z[flange] - 2.0) / 20.0)
    flank = (np.arange(x.size) > top) & flange
    # Flank wear: full from z = 7 to 14 mm (both Sd heights), fading out towards the crest
    # over 12 mm so the flank stays monotonic and the crest keeps its arc.
    weight = (
        _smoothstep((x[flank] - x_top) / 4.0)
        * _smoothstep((z[flank] - 1.0) / 6.0)
        * (1.0 - _smoothstep((z[flank] - 14.0) / 12.0))
    )
    x[flank] -= wear.flange_thinning_mm * weight
    tread = (x > x_top + 20.0) & (z > -FACE_DEPTH_MM + 1.0)
    z[tread] -= wear.hollow_depth_mm * np.exp(-(((x[tread] - 75.0) / 12.0) ** 2))
    return x, z


def _reference_height(x: np.ndarray, z: np.ndarray) -> float:
    """z of the outline at x = 70 on the tread (the part after the flange top)."""
    top = int(np.argmax(z))
    tread_x, tread_z = x[top:], z[top:]
    i = int(np.flatnonzero(tread_x >= REFERENCE_X_MM)[0])
    t = (REFERENCE_X_MM - tread_x[i - 1]) / (tread_x[i] - tread_x[i - 1])
    return float(tread_z[i - 1] + t * (tread_z[i] - tread_z[i - 1]))


def wheel_profile(reference: ReferenceProfile, wear: Wear | None = None) -> WheelProfile:
    """The rim outline of a wheel with `reference` profile and optional `wear`.

    Parameters
    ----------
    reference : ReferenceProfile
    wear : Wear, optional
        None or zero wear gives the reference profile itself.

    Returns
    -------
    WheelProfile
        With its exact true parameters.
    """
    wear = wear or Wear()
    if not 0 <= wear.flange_thinning_mm <= 4 or not 0 <= wear.hollow_depth_mm <= 3:
        raise ValueError(f"wear must have thinning in [0, 4] and hollow in [0, 3] mm, got {wear}")
    if not -3 <= wear.flange_height_change_mm <= 4:
        raise ValueError(
            f"flange_height_change_mm must be in [-3, 4], got {wear.flange_height_change_mm}"
        )
    x, z = _outline(reference)
    x, z = _apply_wear(x, z, wear)
    z = z - _reference_height(x, z)
    x = np.ascontiguousarray(x, dtype=GEOMETRY_FLOAT)
    z = np.ascontiguousarray(z, dtype=GEOMETRY_FLOAT)
    return WheelProfile(reference.name, x, z, curve_flange_parameters(x, z))


def outward_normals(x_mm: np.ndarray, z_mm: np.ndarray) -> np.ndarray:
    """Unit outward normals (n_x, n_z) of an outline traversed back face → field face, (K, 2).

    The material lies to the right of the direction of travel, so the outward normal is the
    tangent (dx, dz) turned by +90°: (−dz, dx).
    """
    dx = np.gradient(x_mm)
    dz = np.gradient(z_mm)
    length = np.hypot(dx, dz)
    return np.column_stack([-dz / length, dx / length])


def radius_envelope(profile: WheelProfile, x_grid_mm: np.ndarray) -> np.ndarray:
    """Largest z of the outline over each x of a grid (−inf outside the rim) [mm].

    Used to test whether a point lies inside the wheel (occlusion); the outline is a graph
    z(x) apart from its vertical faces, so the envelope is the outline itself there.
    """
    envelope = np.full(x_grid_mm.shape, -np.inf)
    inside = (x_grid_mm >= profile.x_mm.min()) & (x_grid_mm <= profile.x_mm.max())
    x, z = profile.x_mm, profile.z_mm
    graph = (x > x.min()) & (x < x.max())
    order = np.argsort(x[graph], kind="stable")
    envelope[inside] = np.interp(x_grid_mm[inside], x[graph][order], z[graph][order])
    return envelope
