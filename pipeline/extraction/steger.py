"""Steger's sub-pixel line centre: second-order Taylor step along the normal, ±0.5 px test.

Equations: docs/extraction.md §5.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pipeline.extraction.gaussian import GaussianDerivatives
from pipeline.extraction.hessian import hessian_eigen
from pipeline.extraction.scalespace import ScaleLevel, cubic_at, cubic_taps, level_coordinate
from pipeline.jit import kernel

MAX_OFFSET_PX = 0.5
"""A centre is kept only inside its own pixel: |t·nx| ≤ 0.5 and |t·ny| ≤ 0.5 (paper eq. (10))."""


@dataclass(frozen=True, slots=True, eq=False)
class LineAnalysis:
    """Line analysis at a set of pixels at one scale; float32 arrays of one shape.

    `lambda1`, `lambda2` (|λ1| ≥ |λ2|) in grey levels/px²; (`nx`, `ny`) the unit normal;
    `offset_px` the signed Taylor step t [px] along the normal from the pixel centre to the
    line centre.
    """

    sigma_px: float
    lambda1: np.ndarray
    lambda2: np.ndarray
    nx: np.ndarray
    ny: np.ndarray
    offset_px: np.ndarray


def analyse_lines(derivatives: GaussianDerivatives) -> LineAnalysis:
    """Hessian eigen-analysis and Taylor step from Gaussian derivatives (any array shape).

    Notes
    -----
    Paper eq. (8): t = −(nx·Ix + ny·Iy) / (nx²·Ixx + 2·nx·ny·Ixy + ny²·Iyy). Because (nx, ny)
    is the unit eigenvector of λ1, the denominator equals λ1. Where λ1 = 0 there is no
    extremum and t = +inf (rejected by the ±0.5 px test).
    """
    eigen = hessian_eigen(derivatives.ixx, derivatives.ixy, derivatives.iyy)
    numerator = -(eigen.nx * derivatives.ix + eigen.ny * derivatives.iy)
    with np.errstate(divide="ignore", invalid="ignore"):
        offset = numerator / eigen.lambda1
    offset = np.where(eigen.lambda1 == 0, np.inf, offset).astype(eigen.lambda1.dtype, copy=False)
    return LineAnalysis(
        sigma_px=derivatives.sigma_px,
        lambda1=eigen.lambda1,
        lambda2=eigen.lambda2,
        nx=eigen.nx,
        ny=eigen.ny,
        offset_px=offset,
    )


def centre_pixels(
    rows: np.ndarray,
    cols: np.ndarray,
    lines: LineAnalysis,
    strength: np.ndarray,
    shape: tuple[int, int],
) -> np.ndarray:
    """Which candidate pixels hold a bright-line centre.

    Parameters
    ----------
    rows, cols : ndarray of shape (K,), int
        Candidate pixels (unique).
    lines : LineAnalysis
        Line analysis at the candidates (arrays (K,)).
    strength : ndarray of shape (K,)
        Line strength used to settle seams (σ²|λ1|).
    shape : tuple of int
        Frame shape (M, N).

    Returns
    -------
    ndarray of shape (K,), bool

    Notes
    -----
    A bright line has λ1 < 0; the centre lies in the pixel when |t·nx| ≤ 0.5 and
    |t·ny| ≤ 0.5 (paper eq. (10)), so each centre is found by one pixel. Where neighbouring
    pixels analysed the line at different scales their centres can disagree by a few tenths
    of a pixel, so that each points into the other and neither holds one: a seam. There, the
    strongest prediction landing in a pixel that no centre occupies is kept (one per pixel,
    its source pixel then taken too), which closes the seam without duplicating centres.
    """
    return _centre_pixels(
        np.asarray(rows, np.int64),
        np.asarray(cols, np.int64),
        lines.offset_px,
        lines.nx,
        lines.ny,
        lines.lambda1,
        np.asarray(strength),
        shape[0],
        shape[1],
    )


@kernel
def _centre_pixels(rows, cols, offset, nx, ny, lambda1, strength, height, width):
    """`centre_pixels` on arrays (K,): accepted centres, then the seams strongest first."""
    count = rows.size
    accepted = np.zeros(count, np.bool_)
    seam = np.zeros(count, np.bool_)
    target_r = np.empty(count, np.int64)
    target_c = np.empty(count, np.int64)
    if count == 0:
        return accepted
    # Occupancy of the candidates' bounding box only; a target lies within 2 px of its pixel.
    r0, c0 = rows.min() - 2, cols.min() - 2
    occupied = np.zeros((rows.max() - r0 + 3, cols.max() - c0 + 3), np.bool_)
    # The tests by selects (the loop vectorises; a lit frame has 115k candidates), then
    # the accepted pixels marked.
    for k in range(count):
        dx, dy = offset[k] * nx[k], offset[k] * ny[k]
        bright = lambda1[k] < 0
        near_x, near_y = abs(dx) <= 1.5, abs(dy) <= 1.5
        accepted[k] = bright & (abs(dx) <= MAX_OFFSET_PX) & (abs(dy) <= MAX_OFFSET_PX)
        # NaN or far steps (not near) give no target; rint only of the near ones.
        target_r[k] = rows[k] + int(np.rint(dy if near_y else 0.0)) if near_y else -1
        target_c[k] = cols[k] + int(np.rint(dx if near_x else 0.0)) if near_x else -1
        inside = (target_r[k] >= 0) & (target_r[k] < height)
        inside &= (target_c[k] >= 0) & (target_c[k] < width)
        seam[k] = bright & (not accepted[k]) & near_x & near_y & inside
    for k in range(count):
        if accepted[k]:
            occupied[rows[k] - r0, cols[k] - c0] = True
    candidates = np.flatnonzero(seam)
    free = np.zeros(candidates.size, np.bool_)
    for i in range(candidates.size):
        k = candidates[i]
        free[i] = not occupied[target_r[k] - r0, target_c[k] - c0]
    candidates = candidates[free]
    order = np.argsort(-strength[candidates], kind="mergesort")  # stable
    for k in candidates[order]:
        target = (target_r[k] - r0, target_c[k] - c0)
        source = (rows[k] - r0, cols[k] - c0)
        if occupied[target] or occupied[source]:
            continue
        occupied[target] = occupied[source] = True
        accepted[k] = True
    return accepted


def newton_step(level: ScaleLevel, x: np.ndarray, y: np.ndarray, nx, ny) -> np.ndarray:
    """Second Taylor step t₂ [px] along the normal, taken at the sub-pixel centres.

    Parameters
    ----------
    level : ScaleLevel
        The scale the centres were found at.
    x, y : ndarray of shape (K,)
        First sub-pixel centres [px] (paper eq. (9)).
    nx, ny : ndarray of shape (K,)
        Their unit normals.

    Returns
    -------
    ndarray of shape (K,), float64
        t₂ = −(n·∇I)/(nᵀHn) with the derivatives interpolated (Keys cubic) at (x, y); 0 where
        nᵀHn ≥ 0 or |t₂| > MAX_OFFSET_PX (no trustworthy second step).

    Notes
    -----
    The first step comes from a quadratic model at the pixel centre, up to 0.7 px from the
    line; on a Gaussian profile of total scale σt it leaves an error ≈ −t³/σt², 0.013 px at
    t = 0.5 px for a 5 px stripe at σ = 2.9 px. A second step from the first estimate, where
    t is near 0, removes it (Newton's method on the first derivative along the normal).
    """
    d = level.derivatives
    out = np.empty(np.size(x))
    fx, fy, fnx, fny = (np.ascontiguousarray(a, np.float64) for a in (x, y, nx, ny))
    _newton_steps((d.ix, d.iy, d.ixx, d.ixy, d.iyy), level.stride, fx, fy, fnx, fny, out)
    return out


@kernel
def _newton_steps(fields, stride, x, y, nx, ny, out) -> None:
    """`newton_step` per point: Keys cubic derivatives at the level coordinates, in frame
    units, and the trusted step."""
    height, width = fields[0].shape
    first = np.float32(1 / stride)
    second = first * first
    for k in range(x.size):
        u, v = level_coordinate(x[k], stride), level_coordinate(y[k], stride)
        taps = cubic_taps(np.float64(u), np.float64(v), height, width)
        gx = np.float32(cubic_at(fields[0], *taps)) * first
        gy = np.float32(cubic_at(fields[1], *taps)) * first
        hxx = np.float32(cubic_at(fields[2], *taps)) * second
        hxy = np.float32(cubic_at(fields[3], *taps)) * second
        hyy = np.float32(cubic_at(fields[4], *taps)) * second
        slope = nx[k] * gx + ny[k] * gy
        curvature = nx[k] * nx[k] * hxx + 2 * nx[k] * ny[k] * hxy + ny[k] * ny[k] * hyy
        step = -slope / curvature
        out[k] = step if curvature < 0 and abs(step) <= MAX_OFFSET_PX else 0.0
