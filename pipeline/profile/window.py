"""Where a wheel's profile can lie in the laser plane: the station's prior on stripe points.

A wheel stands on the rail, so at its lowest section the tread's reference point is at the
rail top (track Z ≈ 0) and the profile frame's z is −Z. Across the axle its back face is
half a back-to-back from the track centre, give or take the wheelset's lateral shift. So
every point of a wheel's stripe lies near one of the reference profiles (LMA, S1002, with
their back and field faces), shifted sideways within that range, give or take the wear. A
centre whose track point is farther from all of them is on something else: the rail, a
brake part, a silhouette or a bright corner of the scene.
"""

from __future__ import annotations

from functools import cache

import numpy as np
from scipy.spatial import cKDTree

from pipeline.calibration.search_region import HALF_BACK_TO_BACK_MM, LATERAL_SHIFT_MM
from pipeline.profile.reference import REFERENCE_PROFILES, load_reference_profile

WEAR_TOLERANCE_MM = 6.0
"""How far a worn wheel's profile can be from its reference profile: flange height ±4 mm,
flank wear up to 4 mm, hollow tread up to 3 mm, plus the 1–2 mm the radius and the plane's
offset from the lowest section move the section."""
FACE_DEPTH_MM = 45.0
"""The back and field faces are part of the prior down to z = −45 mm (the rim's inner edge)."""
STEP_MM = 0.5
"""Sampling of the prior curves along the profile and across the shifts [mm]."""
REGISTER_TOLERANCE_MM = 1.5
REGISTER_POINTS = 1500
MIN_REGISTERED_POINTS = 100
"""The back face is placed where most of (up to 1500 of) the points lie within 1.5 mm of a
reference profile; a wheel's stripe puts hundreds there."""


def _with_faces(name: str) -> tuple[np.ndarray, np.ndarray]:
    """A reference profile with its back face (x = 0) and field face (x = last) added."""
    profile = load_reference_profile(name)
    x = np.concatenate([[0.0, 0.0], profile.x_mm, [profile.x_mm[-1]] * 2])
    z = np.concatenate(
        [[-FACE_DEPTH_MM, profile.z_mm[0]], profile.z_mm, [profile.z_mm[-1], -FACE_DEPTH_MM]]
    )
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(x), np.diff(z)))])
    at = np.arange(0.0, arc[-1], STEP_MM)
    return np.interp(at, arc, x), np.interp(at, arc, z)


def _shifts() -> np.ndarray:
    """Every possible back-face position |X| [mm]: half back-to-back ± lateral shift."""
    return np.arange(
        HALF_BACK_TO_BACK_MM[0] - LATERAL_SHIFT_MM,
        HALF_BACK_TO_BACK_MM[1] + LATERAL_SHIFT_MM + STEP_MM / 2,
        STEP_MM,
    )


@cache
def _prior_tree(shift_mm: float | None) -> cKDTree:
    """The reference profiles with their back face at |X| = shift (None: at every possible
    position) in the (|X|, −Z) plane."""
    shifts = _shifts() if shift_mm is None else np.array([shift_mm])
    curves = []
    for name in REFERENCE_PROFILES:
        x, z = _with_faces(name)
        curves += [np.column_stack([x + shift, z]) for shift in shifts]
    return cKDTree(np.concatenate(curves))


def _plane(points_track_mm: np.ndarray, side: str) -> np.ndarray:
    if side not in ("left", "right"):
        raise ValueError(f"side must be 'left' or 'right', got {side!r}")
    points = np.asarray(points_track_mm, float).reshape(-1, 3)
    sign = 1.0 if side == "right" else -1.0
    return np.column_stack([sign * points[:, 0], -points[:, 2]])


def in_wheel_window(
    points_track_mm: np.ndarray, side: str, *, back_face_mm: float | None = None
) -> np.ndarray:
    """Which track points can be on a wheel of `side` in the laser plane.

    Parameters
    ----------
    points_track_mm : ndarray of shape (K, 3)
        Stripe points in the track frame [mm].
    side : str
        "left" or "right".
    back_face_mm : float, optional
        |X| of the wheel's back face when known (`locate_back_face`); otherwise every
        possible position.

    Returns
    -------
    ndarray of shape (K,), bool
        Points within `WEAR_TOLERANCE_MM` of a reference profile (with its faces) whose
        back face is at a possible |X|, z = −Z.
    """
    plane = _plane(points_track_mm, side)
    tree = _prior_tree(None if back_face_mm is None else round(float(back_face_mm), 1))
    distance, _ = tree.query(plane, distance_upper_bound=WEAR_TOLERANCE_MM)
    return np.isfinite(distance)


def locate_back_face(points_track_mm: np.ndarray, side: str) -> float | None:
    """|X| of the back face that puts the most points within `REGISTER_TOLERANCE_MM` of a
    reference profile [mm]: the wheel's lateral position, which stray lines do not share.
    None when no position holds `MIN_REGISTERED_POINTS`."""
    plane = _plane(points_track_mm, side)
    if plane.shape[0] > REGISTER_POINTS:
        plane = plane[:: plane.shape[0] // REGISTER_POINTS + 1]
    shifts = _shifts()
    counts = np.zeros(shifts.size)
    for name in REFERENCE_PROFILES:
        tree = cKDTree(np.column_stack(_with_faces(name)))
        for i, shift in enumerate(shifts):
            d, _ = tree.query(plane - [shift, 0.0], distance_upper_bound=REGISTER_TOLERANCE_MM)
            counts[i] = max(counts[i], np.count_nonzero(np.isfinite(d)))
    best = int(np.argmax(counts))
    return float(shifts[best]) if counts[best] >= MIN_REGISTERED_POINTS else None
