"""Centres refined on the frame's own profile along the normal, with a kernel matched to the
stripe's width.

Steger's centre at σB is the zero of the first derivative of the frame smoothed at σB in 2-D.
Across the stripe σB = w/√3 is about 2.3× the profile's standard deviation s = w/4, and a
derivative-of-Gaussian of scale b finds a Gaussian line's centre with
((b² + s²)/(2bs))³ times the variance of the Cramér–Rao bound (2.6× at b = 2.3s, 1 at
b = s: the matched filter, the maximum-likelihood shift of a known profile). Along the
normal the raw profile of a line is symmetric about it whatever the line's curvature (the
normal of a circle runs through its centre), so the matched zero crossing has no curvature
bias either; the averaging along the stripe is left to a local quadratic fit of the centres
(`curvature.fitted_offsets`), which follows the line's curvature instead of biasing it.
"""

from __future__ import annotations

import math

import numpy as np

from pipeline.extraction.scalespace import cubic_at, cubic_taps
from pipeline.jit import kernel

PROFILE_STEP_PX = 0.5
"""The frame is read along the normal every 0.5 px (Keys cubic): the kernel's Riemann sum
is exact to e^(−2π²s²/h²) < 10⁻¹⁷ for s ≥ 1 px."""

KERNEL_REACH_SIGMAS = 4.0
"""The matched derivative-of-Gaussian is truncated at ±4s (weight e⁻⁸ at the cut)."""

MIN_PROFILE_SIGMA_PX = 1.0
"""Least s of the matched kernel [px] (a 4 px wide stripe)."""

MAX_MOVE_PX = 1.0
"""A refined centre within this distance of Steger's along the normal is kept [px]; farther
(a neighbour's flank, a step) the Steger centre stays."""

NEWTON_STEPS = 5
"""Newton steps on the matched profile's first derivative (each clipped to ±0.5 px)."""


@kernel
def _matched_offsets(image, x, y, nx, ny, s, out) -> None:
    height, width = image.shape
    for k in range(x.size):
        sk = max(s[k], MIN_PROFILE_SIGMA_PX)
        n = int(math.ceil((KERNEL_REACH_SIGMAS * sk + MAX_MOVE_PX) / PROFILE_STEP_PX))
        profile = np.empty(2 * n + 1)
        for i in range(-n, n + 1):
            t = i * PROFILE_STEP_PX
            rows, cols, wv, wu = cubic_taps(x[k] + t * nx[k], y[k] + t * ny[k], height, width)
            profile[i + n] = cubic_at(image, rows, cols, wv, wu)
        inv = 1.0 / (sk * sk)
        t = 0.0
        ok = True
        for _ in range(NEWTON_STEPS):
            slope = 0.0
            curvature = 0.0
            for i in range(-n, n + 1):
                u = t - i * PROFILE_STEP_PX
                g = math.exp(-0.5 * u * u * inv)
                slope -= profile[i + n] * u * inv * g
                curvature += profile[i + n] * (u * u * inv - 1.0) * inv * g
            if not curvature < 0:
                ok = False
                break
            t -= min(max(slope / curvature, -0.5), 0.5)
            if abs(t) > MAX_MOVE_PX:
                ok = False
                break
        out[k] = t if ok else np.nan


def matched_offsets(
    image: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
    nx: np.ndarray,
    ny: np.ndarray,
    profile_sigma_px: np.ndarray,
) -> np.ndarray:
    """Offset [px] along n from each centre to the zero of the matched profile's slope.

    Parameters
    ----------
    image : ndarray of shape (M, N), uint8, uint16 or float
        The frame [grey levels].
    x, y, nx, ny : ndarray of shape (K,)
        Centres [px] and unit normals.
    profile_sigma_px : ndarray of shape (K,)
        Standard deviation s of each cross-section [px] (a quarter of its 1/e² width), the
        scale of the matched kernel (at least MIN_PROFILE_SIGMA_PX).

    Returns
    -------
    ndarray of shape (K,), float64
        t such that the frame's profile along n, smoothed by a Gaussian of s, peaks at
        (x, y) + t·n; NaN where it is no maximum within MAX_MOVE_PX.
    """
    out = np.empty(np.size(x))
    fx, fy, fnx, fny, fs = (
        np.ascontiguousarray(a, np.float64) for a in (x, y, nx, ny, profile_sigma_px)
    )
    _matched_offsets(np.ascontiguousarray(image), fx, fy, fnx, fny, fs, out)
    return out
