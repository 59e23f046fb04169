"""Stripe width per centre point from the two edges along the normal (as HALCON lines_gauss)."""

from __future__ import annotations

import cv2
import numpy as np

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
    gradient: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
    nx: np.ndarray,
    ny: np.ndarray,
    sigma_px: float,
    *,
    reach_px: float,
) -> np.ndarray:
    """Width of the stripe [px] at centre points that share one scale.

    Parameters
    ----------
    gradient : ndarray of shape (M, N), float32
        Gradient magnitude |∇I| at scale `sigma_px` [grey levels/px].
    x, y, nx, ny : ndarray of shape (K,)
        Sub-pixel centres [px] and unit normals.
    sigma_px : float
        The scale of `gradient` [px].
    reach_px : float
        How far along the normal the edges are searched on each side [px].

    Returns
    -------
    ndarray of shape (K,), float64
        1/e² full width of the equivalent Gaussian profile [px]; NaN where an edge was not found.

    Notes
    -----
    A Gaussian profile of standard deviation s smoothed at σ has its steepest slope at
    ±√(s² + σ²). With d the mean distance of the two gradient maxima from the centre,
    s = √(d² − σ²) and the width is 4s, which is the true 1/e² width of a Gaussian stripe.
    """
    steps = np.arange(1, int(np.ceil(reach_px / STEP_PX)) + 1) * STEP_PX
    distances = []
    for sign in (1.0, -1.0):
        map_x = (x[:, None] + sign * steps[None, :] * nx[:, None]).astype(np.float32)
        map_y = (y[:, None] + sign * steps[None, :] * ny[:, None]).astype(np.float32)
        profile = cv2.remap(gradient, map_x, map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT)
        distances.append(_edge_distance(profile))
    half = 0.5 * (distances[0] + distances[1])
    return 4 * np.sqrt(np.maximum(half**2 - sigma_px**2, 0))
