"""Stripe width per centre point from the two edges along the normal (as HALCON lines_gauss)."""

from __future__ import annotations

import cv2
import numpy as np

from pipeline.gaussian import BORDER
from pipeline.scalespace import ScaleLevel, interpolate_cubic

STEP_PX = 0.25
"""Sampling step of the coarse search along the normal [px]."""

REFINE_STEP_PX = 0.5
"""Spacing of the cubic samples that refine each edge [px]."""


def _edge_distance(profile: np.ndarray) -> np.ndarray:
    """Distance [px] of the gradient maximum in each row of samples taken at STEP_PX, 2·STEP_PX….

    Rows whose maximum sits at either end (no edge within reach) get NaN.
    """
    k = np.argmax(profile, axis=1)
    interior = (k > 0) & (k < profile.shape[1] - 1)
    return np.where(interior, (k + 1) * STEP_PX, np.nan)


def _refine_peak(level: ScaleLevel, ray, distance: np.ndarray) -> np.ndarray:
    """Refine maxima of |∇I| along rays (x, y, dx, dy) with cubic samples and a parabola.

    Five samples REFINE_STEP_PX apart around the coarse maximum pick the best node; a
    parabola through it and its neighbours gives the sub-sample position [px].
    """
    x, y, dx, dy = ray
    d = level.derivatives
    offsets = REFINE_STEP_PX * np.arange(-2, 3)
    samples = []
    for offset in offsets:
        u = level.to_level(x + (distance + offset) * dx)
        v = level.to_level(y + (distance + offset) * dy)
        samples.append(np.hypot(interpolate_cubic(d.ix, u, v), interpolate_cubic(d.iy, u, v)))
    profile = np.stack(samples, axis=1)
    k = np.clip(np.argmax(profile, axis=1), 1, 3)
    rows = np.arange(profile.shape[0])
    left, mid, right = (profile[rows, k + j] for j in (-1, 0, 1))
    curvature = left - 2 * mid + right
    with np.errstate(divide="ignore", invalid="ignore"):
        shift = np.where(curvature < 0, 0.5 * (left - right) / curvature, 0)
    return distance + offsets[k] + np.clip(shift, -1, 1) * REFINE_STEP_PX


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
        The scale whose first derivatives are sampled.
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
    The maxima are found on a bilinear profile, then refined on cubic samples (a bilinear
    profile peaks at grid nodes, which would bias d by up to half a pixel).
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
        coarse = _edge_distance(np.hypot(gx, gy))
        found = np.flatnonzero(np.isfinite(coarse))
        ray = (x[found], y[found], sign * nx[found], sign * ny[found])
        refined = np.full(x.size, np.nan)
        refined[found] = _refine_peak(level, ray, coarse[found])
        distances.append(refined)
    half = 0.5 * (distances[0] + distances[1])
    return 4 * np.sqrt(np.maximum(half**2 - level.sigma_px**2, 0))
