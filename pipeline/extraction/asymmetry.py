"""Removal of the centre bias of asymmetric stripe cross-sections, from two scales.

Where the surface's slope or reflectance changes across the lit band, the cross-section is
wider on one side of the true line than on the other. Gaussian smoothing moves its maximum
(Steger's centre) towards the wide side, and the more so the larger the scale: a two-sided
Gaussian of half-widths s̄(1 ∓ α) smoothed at σ moves by c = s̄·F(σ/s̄, α).
Smoothed at σ the profile stays nearly symmetric about its moved maximum (its edges and
edge contrasts differ by 1–2 % when c = 0.2σ), so the edges cannot tell the bias; the
maximum's move between two scales can. With the width giving s̄, the move Δ between the
centre's scale σa and a second scale σb fixes α through F(σb/s̄, α) − F(σa/s̄, α) = Δ/s̄,
and then the bias s̄·F(σa/s̄, α) (the model of Steger's asymmetric bar, with the side
widths as the unknowns instead of the side levels).
"""

from __future__ import annotations

from functools import cache

import numpy as np
from scipy.interpolate import RegularGridInterpolator
from scipy.special import ndtr

from pipeline.extraction.scalespace import ScaleLevel, interpolate_cubic_fields

SCALE_RATIOS = np.geomspace(0.25, 12.0, 40)
"""σ/s̄ of the table (s̄ the mean half-width of the cross-section)."""
SKEWS = np.linspace(-0.6, 0.6, 49)
"""α of the table: half-widths s̄(1 − α) on the −n side, s̄(1 + α) on the +n side."""
TABLE_STEP = 0.01
"""Sampling of the tabulated profiles, in units of the smoothed profile's scale, refined by
a parabola through the top three samples (the maxima lie within ±2 of it: the bias is below
the mean offset of the two halves)."""
PEAK_ITERATIONS = 4
"""Newton steps to the maximum at the second scale (each ≤ 1 px, from the centre)."""
SMOOTHING_SIGMAS = 2.0
MIN_SMOOTHING_POINTS = 4
"""The move Δ is averaged along the polyline over ±2σ (at least ±4 points): the asymmetry
changes slowly along a stripe, the maximum's noise at the second scale does not."""


def _half_smoothed(u: np.ndarray, s: np.ndarray, sign: float) -> np.ndarray:
    """∫ exp(−t²/2s²)·φ(u − t) dt over the half line sign·t ≥ 0 (φ the unit Gaussian)."""
    v = s**2 / (1 + s**2)
    return np.sqrt(v) * np.exp(-0.5 * u**2 / (1 + s**2)) * ndtr(sign * u * s / np.sqrt(1 + s**2))


@cache
def _bias_table() -> RegularGridInterpolator:
    """F(σ/s̄, α) = c/s̄: the maximum of the two-sided Gaussian smoothed at σ.

    In units of σ the profile exp(−u²/2s₋²) (u < 0), exp(−u²/2s₊²) (u ≥ 0) smoothed at 1 is
    the sum of two half-Gaussians in closed form; its maximum is found on a grid of
    `TABLE_STEP` × the smoothed profile's scale √(1 + (s̄/σ)²).
    """
    values = np.empty((SCALE_RATIOS.size, SKEWS.size))
    for i, ratio in enumerate(SCALE_RATIOS):
        scale = np.sqrt(1.0 + ratio**-2)
        u = np.arange(-2.0 * scale, 2.0 * scale, TABLE_STEP * scale)[None, :]
        minus, plus = ((1 - SKEWS) / ratio)[:, None], ((1 + SKEWS) / ratio)[:, None]
        smooth = _half_smoothed(u, minus, -1.0) + _half_smoothed(u, plus, 1.0)
        top = np.clip(np.argmax(smooth, axis=1), 1, u.shape[1] - 2)
        left, mid, right = (
            np.take_along_axis(smooth, (top + k)[:, None], 1)[:, 0] for k in (-1, 0, 1)
        )
        shift = 0.5 * (left - right) / (left - 2 * mid + right)  # parabola through the top
        values[i] = (u[0, top] + shift * TABLE_STEP * scale) * ratio  # c/σ → c/s̄
    return RegularGridInterpolator((SCALE_RATIOS, SKEWS), values, bounds_error=False)


def peak_offsets(level: ScaleLevel, x, y, nx, ny) -> np.ndarray:
    """Offset [px] along n from (x, y) to the maximum of the profile at `level`'s scale.

    Newton's method on the first derivative along the normal, derivatives by Keys cubic
    interpolation; NaN where the profile is not a maximum there (nᵀHn ≥ 0).
    """
    d = level.derivatives
    fields = (d.ix, d.iy, d.ixx, d.ixy, d.iyy)
    origin, stride = 0.5 * (level.stride - 1), float(level.stride)
    t = np.zeros(np.size(x))
    peak = np.ones(np.size(x), bool)
    for _ in range(PEAK_ITERATIONS):
        # t stays finite (a NaN coordinate would index the fields nowhere).
        u = (x + t * nx - origin) / stride
        v = (y + t * ny - origin) / stride
        ix, iy, ixx, ixy, iyy = interpolate_cubic_fields(fields, u, v)
        slope = (nx * ix + ny * iy) / stride
        curvature = (nx * nx * ixx + 2 * nx * ny * ixy + ny * ny * iyy) / stride**2
        peak &= curvature < 0
        step = np.where(peak, -slope / np.minimum(curvature, -1e-12), 0.0)
        t = t + np.clip(step, -1.0, 1.0)
    return np.where(peak, t, np.nan)


def _along(values: np.ndarray, sigma: np.ndarray, chain: np.ndarray) -> np.ndarray:
    """Moving mean of the finite values over each point's ±max(2σ, 4) chain neighbours."""
    v = values[chain]
    ok = np.isfinite(v)
    sums = np.concatenate([[0.0], np.cumsum(np.where(ok, v, 0.0))])
    counts = np.concatenate([[0], np.cumsum(ok)])
    half = np.maximum(np.ceil(SMOOTHING_SIGMAS * sigma[chain]), MIN_SMOOTHING_POINTS).astype(int)
    index = np.arange(chain.size)
    lo, hi = np.clip(index - half, 0, chain.size), np.clip(index + half + 1, 0, chain.size)
    n = counts[hi] - counts[lo]
    return np.where(n > 0, (sums[hi] - sums[lo]) / np.maximum(n, 1), np.nan)


SIGNIFICANCE_Z = 3.0
TEST_SIGMAS = 6.0
MIN_TEST_POINTS = 12
CORRELATION_SIGMAS = 2.0
"""The bias is removed only where the measured asymmetry is significant: the mean move over
±6σ along the polyline (at least ±12 points) exceeds 3 standard errors of that mean. The
moves of neighbouring centres share the smoothing at both scales, so the standard error
counts one independent move per 2σ of polyline (the effective sample size n / 2σ). On one
pass of the field benchmark's train (seed 2027) the gate takes the cost on clean frames
from Sh / Sd MAE +0.024 / +0.031 mm to +0.008 / +0.027 (uncorrected 0.002 / 0.011) and
keeps part of the gain on the asymmetry-only frames (uncorrected 0.108 / 0.055, corrected
without the gate 0.039 / 0.013, with it 0.060 / 0.043). A clean stripe's maximum still
moves significantly between scales near the flange (the larger scale reaches the folded
stripe beside it): that move is not asymmetry, and no noise test can tell it from one;
±12σ windows or z = 2 traded the two cases no better."""


def _significant(values: np.ndarray, sigma: np.ndarray, chain: np.ndarray) -> np.ndarray:
    """True where the moving mean of the finite values over ±max(TEST_SIGMAS σ,
    MIN_TEST_POINTS) chain neighbours differs from 0 by more than SIGNIFICANCE_Z standard
    errors (effective sample size n / (CORRELATION_SIGMAS σ))."""
    v = values[chain]
    ok = np.isfinite(v)
    v = np.where(ok, v, 0.0)
    sums = np.concatenate([[0.0], np.cumsum(v)])
    squares = np.concatenate([[0.0], np.cumsum(v * v)])
    counts = np.concatenate([[0], np.cumsum(ok)])
    half = np.maximum(np.ceil(TEST_SIGMAS * sigma[chain]), MIN_TEST_POINTS).astype(int)
    index = np.arange(chain.size)
    lo, hi = np.clip(index - half, 0, chain.size), np.clip(index + half + 1, 0, chain.size)
    n = counts[hi] - counts[lo]
    mean = (sums[hi] - sums[lo]) / np.maximum(n, 1)
    variance = np.maximum((squares[hi] - squares[lo]) / np.maximum(n, 1) - mean**2, 0.0)
    effective = np.maximum(n / np.maximum(CORRELATION_SIGMAS * sigma[chain], 1.0), 1.0)
    return (n >= 3) & (np.abs(mean) > SIGNIFICANCE_Z * np.sqrt(variance / effective))


def asymmetry_bias(
    moves_px: np.ndarray,
    sigma_px: np.ndarray,
    second_sigma_px: np.ndarray,
    width_px: np.ndarray,
    polylines: tuple[np.ndarray, ...],
    bias_sigma_px: np.ndarray | None = None,
) -> np.ndarray:
    """Bias of each centre along its normal from the maximum's move to a second scale [px].

    Parameters
    ----------
    moves_px : ndarray of shape (K,)
        Offset along +n from each centre to the maximum at the second scale (`peak_offsets`)
        [px]; NaN where there is none.
    sigma_px, second_sigma_px : ndarray of shape (K,)
        The centre's scale and the second scale [px].
    width_px : ndarray of shape (K,)
        1/e² width of the cross-section (4 s̄) [px]; NaN where unknown.
    polylines : tuple of ndarray of int
        Ordered index arrays into the points; the moves are averaged along them.
    bias_sigma_px : ndarray of shape (K,), optional
        The scale whose maximum's bias is returned [px] (the matched kernel's s for
        centres refined by `normal_fit`); default `sigma_px`.

    Returns
    -------
    ndarray of shape (K,), float64
        Signed offset of each centre from the true line along +n [px]: subtract it times n.
        0 where the move, the width or α is out of the table, or the move is not
        significant (`_significant`).

    Notes
    -----
    G(α) = F(σb/s̄, α) − F(σa/s̄, α) is monotone in α for σb ≠ σa; α is read off it on the
    table's α grid, then c = s̄·F(σc/s̄, α) at the scale σc asked for.
    """
    bias_sigma = sigma_px if bias_sigma_px is None else bias_sigma_px
    bias = np.zeros(sigma_px.size)
    table = _bias_table()
    for chain in polylines:
        significant = _significant(moves_px, sigma_px, chain)
        move = _along(moves_px, sigma_px, chain)
        half = 0.25 * _along(width_px, sigma_px, chain)
        half = np.where(half > 0, half, np.nan)
        ra, rb = sigma_px[chain] / half, second_sigma_px[chain] / half
        grid_a = np.stack(np.broadcast_arrays(ra[:, None], SKEWS[None, :]), axis=-1)
        grid_b = np.stack(np.broadcast_arrays(rb[:, None], SKEWS[None, :]), axis=-1)
        fa, fb = table(grid_a), table(grid_b)
        gap = fb - fa
        target = (move / half)[:, None]
        # α where G crosses the measured move (G is monotone: the first sign change).
        below = gap <= target
        crossing = np.argmax(below[:, 1:] != below[:, :-1], axis=1)
        g0 = np.take_along_axis(gap, crossing[:, None], 1)[:, 0]
        g1 = np.take_along_axis(gap, crossing[:, None] + 1, 1)[:, 0]
        w = (target[:, 0] - g0) / np.where(g1 != g0, g1 - g0, np.nan)
        fc = table(
            np.stack(np.broadcast_arrays((bias_sigma[chain] / half)[:, None], SKEWS), axis=-1)
        )
        f0 = np.take_along_axis(fc, crossing[:, None], 1)[:, 0]
        f1 = np.take_along_axis(fc, crossing[:, None] + 1, 1)[:, 0]
        value = half * (f0 + w * (f1 - f0))
        found = np.any(below[:, 1:] != below[:, :-1], axis=1) & (w >= 0) & (w <= 1)
        bias[chain] = np.where(significant & found & np.isfinite(value), value, 0.0)
    return bias
