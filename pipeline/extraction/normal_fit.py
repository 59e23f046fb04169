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

CONVERGED_PX = 1e-2
"""Newton stops once a step is below this [px]. The steps shrink as the square of the one
before (the next is C·step², C ≤ 1 for 99 % of the dark speed frames' centres, median
10⁻⁴–10⁻²), so a step under 0.01 px leaves ≲ 10⁻⁴ px: the centres start at Steger's, and
most converge in one step where 10⁻⁵ px took a second to confirm it (matched_offsets
1.45–1.53 → 1.22–1.36 ms least on the clean and varying-width speed frames; every
accuracy and field-harsh case's RMS the same to 10⁻⁴ px, field-all +0.0002)."""


@kernel
def _span(t, sk, n) -> tuple[int, int]:
    """First and last sample i (at i·PROFILE_STEP_PX, |i| ≤ n) under the kernel of sk
    centred at t [px], truncated at ±KERNEL_REACH_SIGMAS·sk."""
    h = PROFILE_STEP_PX
    reach = KERNEL_REACH_SIGMAS * sk
    return max(int(math.ceil((t - reach) / h)), -n), min(int(math.floor((t + reach) / h)), n)


@kernel
def _first_weight(t, first, inv) -> tuple[float, float, float]:
    """u = t − first·h, the kernel's weight g(u) = e^(−u²/2s²) there and g(u − h)/g(u)."""
    h = PROFILE_STEP_PX
    u = t - first * h
    return u, math.exp(-0.5 * u * u * inv), math.exp((u - 0.5 * h) * h * inv)


@kernel
def _add_sample(value, u, g, ratio, inv, decay, slope, curvature):
    """One sample's terms of the smoothed profile's slope and curvature at the kernel's
    centre, and the recurrence on to the next sample: (u, g, ratio, slope, curvature)."""
    p = value * g
    slope -= p * u
    curvature += p * (u * u * inv - 1.0)
    return u - PROFILE_STEP_PX, g * ratio, ratio * decay, slope, curvature


@kernel
def _newton_step(t, slope, curvature) -> tuple[float, bool]:
    """The next t (NaN where it is no maximum within MAX_MOVE_PX) and whether to stop (a
    step below CONVERGED_PX)."""
    if not curvature < 0:
        return np.nan, True
    step = min(max(slope / curvature, -0.5), 0.5)
    t -= step
    if abs(t) > MAX_MOVE_PX:
        return np.nan, True
    return t, abs(step) < CONVERGED_PX


@kernel
def _newton(profile, n, sk_a, sk_b, both) -> tuple[float, float]:
    """The zeros of the slope of `profile` (samples at (i − n)·PROFILE_STEP_PX) smoothed by
    Gaussians of sk_a and (when `both`) sk_b, by Newton steps from 0; NaN where it is no
    maximum within MAX_MOVE_PX (and for sk_b when not `both`).

    The kernel's weights at u = t − i·h come by recurrence (g(u − h) = g(u)·r, r·= e^(−h²/s²)
    each step): no exp per sample. Each sum is a chain of dependent multiply-adds, so the
    two scales' steps run side by side over the samples both kernels cover (each sum still
    in sample order): the processor overlaps the two chains.
    """
    h = PROFILE_STEP_PX
    inv_a, inv_b = 1.0 / (sk_a * sk_a), 1.0 / (sk_b * sk_b)
    decay_a, decay_b = math.exp(-h * h * inv_a), math.exp(-h * h * inv_b)
    t_a, t_b = 0.0, 0.0 if both else np.nan
    run_a, run_b = True, both
    for _ in range(NEWTON_STEPS):
        first_a, last_a = _span(t_a, sk_a, n)
        first_b, last_b = _span(t_b, sk_b, n) if run_b else (0, -1)
        if not run_a:
            first_a, last_a = first_b, first_b - 1  # no samples, placed where b's start
        if not run_b:
            first_b, last_b = first_a, first_a - 1
        u_a = g_a = r_a = u_b = g_b = r_b = 0.0
        if run_a:
            u_a, g_a, r_a = _first_weight(t_a, first_a, inv_a)
        if run_b:
            u_b, g_b, r_b = _first_weight(t_b, first_b, inv_b)
        slope_a = curvature_a = slope_b = curvature_b = 0.0
        low, high = max(first_a, first_b), min(last_a, last_b)
        if low > high:  # no samples in common: one scale after the other
            low, high = last_a + 1, last_a
        for i in range(first_a, min(low, last_a + 1)):
            u_a, g_a, r_a, slope_a, curvature_a = _add_sample(
                profile[i + n], u_a, g_a, r_a, inv_a, decay_a, slope_a, curvature_a
            )
        for i in range(first_b, min(low, last_b + 1)):
            u_b, g_b, r_b, slope_b, curvature_b = _add_sample(
                profile[i + n], u_b, g_b, r_b, inv_b, decay_b, slope_b, curvature_b
            )
        for i in range(low, high + 1):
            value = profile[i + n]
            u_a, g_a, r_a, slope_a, curvature_a = _add_sample(
                value, u_a, g_a, r_a, inv_a, decay_a, slope_a, curvature_a
            )
            u_b, g_b, r_b, slope_b, curvature_b = _add_sample(
                value, u_b, g_b, r_b, inv_b, decay_b, slope_b, curvature_b
            )
        for i in range(max(high + 1, first_a), last_a + 1):
            u_a, g_a, r_a, slope_a, curvature_a = _add_sample(
                profile[i + n], u_a, g_a, r_a, inv_a, decay_a, slope_a, curvature_a
            )
        for i in range(max(high + 1, first_b), last_b + 1):
            u_b, g_b, r_b, slope_b, curvature_b = _add_sample(
                profile[i + n], u_b, g_b, r_b, inv_b, decay_b, slope_b, curvature_b
            )
        if run_a:
            t_a, stop = _newton_step(t_a, slope_a, curvature_a)
            run_a = not stop
        if run_b:
            t_b, stop = _newton_step(t_b, slope_b, curvature_b)
            run_b = not stop
        if not (run_a or run_b):
            break
    return t_a, t_b


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
        sk = max(s[k], MIN_PROFILE_SIGMA_PX)
        for f in range(0, factors.size, 2):  # two scales at a time (`_newton`)
            both = f + 1 < factors.size
            t_a, t_b = _newton(profile, n, sk * factors[f], sk * factors[f + both], both)
            out[f, k] = t_a
            if both:
                out[f + 1, k] = t_b


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
