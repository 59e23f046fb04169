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

from pipeline.extraction.scalespace import cubic_at, cubic_taps, interior_taps
from pipeline.jit import kernel

PROFILE_STEP_PX = 1.0
"""The frame is read along the normal every 1 px (Keys cubic). The kernel's Riemann sum of a
smooth profile is exact to e^(−2π²s²/h²) < 3·10⁻⁹ for s ≥ 1 px; the cubic's kinks at pixel
boundaries leave 0.002 px RMS on a 5 px wide exact stripe (0.0008 px at 0.5 px steps, at
4.5× the cost)."""

KERNEL_REACH_SIGMAS = 3.5
"""The matched derivative-of-Gaussian is truncated at ±3.5s (Gaussian weight e^−6.1 ≈ 0.002
at the cut). Against ±4s the RMS of every speed, issue-3 and harsh case is the same to
10⁻⁴ px at an eighth fewer profile reads per centre (pipeline 0.10.0: 2.82 → 2.54 ms for
2316 centres); ±3s saved a quarter but cost broken-steps 0.0222 → 0.0230 px and
lit-edge-crossing 0.1505 → 0.1539 px."""

MIN_PROFILE_SIGMA_PX = 1.0
"""Least s of the matched kernel [px] (a 4 px wide stripe)."""

MAX_MOVE_PX = 1.0
"""A refined centre within this distance of Steger's along the normal is kept [px]; farther
(a neighbour's flank, a step) the Steger centre stays."""

NEWTON_STEPS = 5
"""Most Newton steps on the matched profile's first derivative (each clipped to ±0.5 px)."""

CONVERGED_PX = 1e-5
"""Newton stops once a step is below this [px]."""


@kernel
def _newton(profile, n, t, sk) -> float:
    """The zero of the slope of `profile` (samples at (i − n)·PROFILE_STEP_PX) smoothed by a
    Gaussian of sk, by Newton steps from t; NaN where it is no maximum within MAX_MOVE_PX.

    The kernel's weights at u = t − i·h come by recurrence (g(u − h) = g(u)·r, r·= e^(−h²/s²)
    each step): no exp per sample.
    """
    h = PROFILE_STEP_PX
    inv = 1.0 / (sk * sk)
    reach = KERNEL_REACH_SIGMAS * sk
    decay = math.exp(-h * h * inv)
    for _ in range(NEWTON_STEPS):
        first = max(int(math.ceil((t - reach) / h)), -n)
        last = min(int(math.floor((t + reach) / h)), n)
        u = t - first * h
        g = math.exp(-0.5 * u * u * inv)
        ratio = math.exp((u - 0.5 * h) * h * inv)  # g(u − h)/g(u)
        slope = 0.0
        curvature = 0.0
        for i in range(first, last + 1):
            p = profile[i + n] * g
            slope -= p * u
            curvature += p * (u * u * inv - 1.0)
            g *= ratio
            ratio *= decay
            u -= h
        if not curvature < 0:
            return np.nan
        step = min(max(slope / curvature, -0.5), 0.5)
        t -= step
        if abs(t) > MAX_MOVE_PX:
            return np.nan
        if abs(step) < CONVERGED_PX:
            break
    return t


@kernel
def _read_profile(image, x, y, nx, ny, n, profile) -> None:
    """profile[i + n] = Keys cubic grey at (x, y) + i·PROFILE_STEP_PX·(nx, ny), i = −n … n;
    the taps indexed directly where the whole line's lie inside the frame (a pixel of
    margin against rounding), else folded (reflect border)."""
    height, width = image.shape
    reach = n * PROFILE_STEP_PX
    xs, ys = (x - reach * nx, x + reach * nx), (y - reach * ny, y + reach * ny)
    if 2 <= min(xs) and max(xs) < width - 3 and 2 <= min(ys) and max(ys) < height - 3:
        for i in range(-n, n + 1):
            t = i * PROFILE_STEP_PX
            profile[i + n] = cubic_at(image, *interior_taps(x + t * nx, y + t * ny))
    else:
        for i in range(-n, n + 1):
            t = i * PROFILE_STEP_PX
            profile[i + n] = cubic_at(image, *cubic_taps(x + t * nx, y + t * ny, height, width))


@kernel
def _matched_offsets(image, x, y, nx, ny, s, factors, out) -> None:
    """`matched_offsets` into out (F, K): one profile buffer, each centre's profile read once
    for every factor."""
    if x.size == 0:
        return
    widest = np.empty(x.size)
    for k in range(x.size):
        widest[k] = max(s[k], MIN_PROFILE_SIGMA_PX) * factors.max()
    longest = int(math.ceil((KERNEL_REACH_SIGMAS * widest.max() + MAX_MOVE_PX) / PROFILE_STEP_PX))
    profile = np.empty(2 * longest + 1)
    for k in range(x.size):
        n = int(math.ceil((KERNEL_REACH_SIGMAS * widest[k] + MAX_MOVE_PX) / PROFILE_STEP_PX))
        _read_profile(image, x[k], y[k], nx[k], ny[k], n, profile)
        for f in range(factors.size):
            out[f, k] = _newton(profile, n, 0.0, max(s[k], MIN_PROFILE_SIGMA_PX) * factors[f])


def matched_offsets(
    image: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
    nx: np.ndarray,
    ny: np.ndarray,
    profile_sigma_px: np.ndarray,
    factors: tuple[float, ...],
) -> np.ndarray:
    """Offset [px] along n from each centre to the zero of the matched profile's slope.

    Parameters
    ----------
    image : ndarray of shape (M, N), uint8, uint16 or float
        Grey frame, read by Keys cubic interpolation with a reflect border.
    x, y, nx, ny : ndarray of shape (K,)
        Starting centres [px] and their unit normals.
    profile_sigma_px : ndarray of shape (K,)
        Standard deviation s of each cross-section [px] (a quarter of its 1/e² width), at
        least MIN_PROFILE_SIGMA_PX.
    factors : tuple of float
        Kernel scales to try, in units of s (one read of the frame serves them all).

    Returns
    -------
    ndarray of shape (F, K), float64
        Per factor k, t such that the frame's profile along n, smoothed by a Gaussian of
        k·s, peaks at (x, y) + t·n; NaN where it is no maximum within MAX_MOVE_PX.
    """
    out = np.empty((len(factors), np.size(x)))
    fx, fy, fnx, fny, fs = (
        np.ascontiguousarray(a, np.float64) for a in (x, y, nx, ny, profile_sigma_px)
    )
    scales = np.asarray(factors, np.float64)
    _matched_offsets(np.ascontiguousarray(image), fx, fy, fnx, fny, fs, scales, out)
    return out
