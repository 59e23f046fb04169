"""Stripe width per centre point from the two edges along the normal (as HALCON lines_gauss)."""

from __future__ import annotations

import cv2
import numpy as np

from pipeline.gaussian import BORDER
from pipeline.scalespace import ScaleLevel

STEP_PX = 0.25
"""Sampling step along the normal [px]."""


def _edge_distance(profile: np.ndarray) -> np.ndarray:
    """Distance [px] of the gradient maximum in each row of samples taken at STEP_PX, 2·STEP_PX….

    A parabola through the maximum and its two neighbours refines it. Rows whose maximum sits at
    either end (no edge within reach) get NaN.
    """
    k = np.argmax(profile, axis=1)
    rows = np.arange(profile.shape[0])
    interior = (k > 0) & (k < profile.shape[1] - 1)
    kk = np.clip(k, 1, profile.shape[1] - 2)
    left, mid, right = (profile[rows, kk + d] for d in (-1, 0, 1))
    curvature = left - 2 * mid + right
    with np.errstate(divide="ignore", invalid="ignore"):
        shift = np.where(curvature < 0, 0.5 * (left - right) / curvature, 0)
    distance = (kk + np.clip(shift, -0.5, 0.5) + 1) * STEP_PX
    return np.where(interior, distance, np.nan)


def stripe_widths(
    level: ScaleLevel,
    x: np.ndarray,
    y: np.ndarray,
    nx: np.ndarray,
    ny: np.ndarray,
    *,
    reach_px: float,
) -> np.ndarray:
    """Width of the stripe [px] at centre points found at one scale.

    Parameters
    ----------
    level : ScaleLevel
        The scale the points were found at (its first derivatives are sampled).
    x, y, nx, ny : ndarray of shape (K,)
        Sub-pixel centres [px] and unit normals.
    reach_px : float
        How far along the normal the edges are searched on each side [px].

    Returns
    -------
    ndarray of shape (K,), float64
        1/e² full width of the equivalent Gaussian profile [px]; NaN where an edge was not found.

    Notes
    -----
    A Gaussian profile of standard deviation s smoothed at σ has its steepest slope at
    ±√(s² + σ²). With d the mean distance of the two gradient maxima |∇I| from the centre,
    s = √(d² − σ²) and the width is 4s, which is the true 1/e² width of a Gaussian stripe.
    """
    steps = np.arange(1, int(np.ceil(reach_px / STEP_PX)) + 1) * STEP_PX
    derivatives = level.derivatives
    distances = []
    for sign in (1.0, -1.0):
        map_x = level.to_level(x[:, None] + sign * steps[None, :] * nx[:, None])
        map_y = level.to_level(y[:, None] + sign * steps[None, :] * ny[:, None])
        gx, gy = (
            cv2.remap(field, map_x, map_y, cv2.INTER_LINEAR, borderMode=BORDER)
            for field in (derivatives.ix, derivatives.iy)
        )
        distances.append(_edge_distance(np.hypot(gx, gy)))
    half = 0.5 * (distances[0] + distances[1])
    return 4 * np.sqrt(np.maximum(half**2 - level.sigma_px**2, 0))
