"""Stripe width per centre point from the two edges along the normal (as HALCON lines_gauss)."""

from __future__ import annotations

import numpy as np

from pipeline.extraction.scalespace import (
    ScaleLevel,
    bilinear_at,
    blend,
    cubic_at,
    cubic_taps,
    interior_taps,
)
from pipeline.jit import kernel

STEP_PX = 1.0
"""Sampling step of the coarse search along the normal [px]. The refinement spans ±1 px
around the coarse maximum, so a 1 px step still finds the maximum of a smooth profile,
with a quarter of the samples of a 0.25 px step (the search is memory-bound)."""

REFINE_STEP_PX = 0.5
"""Spacing of the cubic samples that refine each edge [px]."""


@kernel
def _bilinear_gradient_squared(ix, iy, r0, r1, c0, c1, fu: float, fv: float) -> float:
    """|∇I|² from Ix, Iy blended between rows r0, r1 and columns c0, c1 (`blend`)."""
    gx = blend(ix, r0, r1, fv, c0, c1, fu)
    gy = blend(iy, r0, r1, fv, c0, c1, fu)
    return gx * gx + gy * gy


@kernel
def _gradient_squared(ix, iy, u: float, v: float) -> float:
    """|∇I|² from bilinear Ix, Iy at level-grid coordinates (u, v), reflect border."""
    height, width = ix.shape
    inside = 0 <= u < width - 1 and 0 <= v < height - 1
    gx = bilinear_at(ix, u, v, inside)
    gy = bilinear_at(iy, u, v, inside)
    return gx * gx + gy * gy


@kernel
def _coarse_interior(ix, iy, x0, y0, dx, dy, steps, origin, scale, values) -> None:
    """values[i] = bilinear |∇I|² at steps[i] [px] along (dx, dy) from (x0, y0) [px] when
    all taps lie inside the grid: `_gradient_squared` without its border branch, unsigned
    indices (no negative-index wraparound)."""
    for i in range(steps.size):
        u = (x0 + steps[i] * dx - origin) * scale
        v = (y0 + steps[i] * dy - origin) * scale
        u0 = np.floor(u)
        v0 = np.floor(v)
        c0, r0 = np.uint64(u0), np.uint64(v0)
        c1, r1 = c0 + np.uint64(1), r0 + np.uint64(1)
        values[i] = _bilinear_gradient_squared(ix, iy, r0, r1, c0, c1, u - u0, v - v0)


@kernel
def _magnitude(gx: float, gy: float) -> float:
    """|∇I| [grey levels/px] as √(gx² + gy²): the squares of grey-level gradients stay far
    inside the float range, so the library's hypot (a call per sample) is not needed."""
    return np.sqrt(gx * gx + gy * gy)


@kernel
def _cubic_gradient_interior(ix, iy, u: float, v: float) -> float:
    """|∇I| from Keys cubic Ix, Iy at level-grid coordinates (u, v) when all 4 × 4 taps lie
    inside the grid (`interior_taps`, shared by both fields)."""
    taps = interior_taps(u, v)
    return _magnitude(cubic_at(ix, *taps), cubic_at(iy, *taps))


@kernel
def _edge_distances(ix, iy, stride, x, y, nx, ny, steps, out) -> None:
    """Distance [px] from each centre to the gradient maximum along ±(nx, ny), NaN if none;
    out[0] along +n, out[1] along −n.

    A coarse maximum of bilinear |∇I| sampled at `steps` is refined with five Keys cubic
    samples REFINE_STEP_PX apart and a parabola through the best one and its neighbours
    (a bilinear profile peaks at grid nodes, which would bias the distance by up to ½ px).
    The maximum must lie strictly inside the searched reach.
    """
    origin = 0.5 * (stride - 1)
    scale = 1.0 / stride  # exact: the stride is a power of 2
    height, width = ix.shape
    refined = np.empty(5)
    values = np.empty(steps.size)
    for side in range(2):
        for k in range(x.size):
            xk, yk = x[k], y[k]
            dx, dy = (nx[k], ny[k]) if side == 0 else (-nx[k], -ny[k])
            last = steps[steps.size - 1]
            u_first = (xk + steps[0] * dx - origin) * scale
            v_first = (yk + steps[0] * dy - origin) * scale
            u_last = (xk + last * dx - origin) * scale
            v_last = (yk + last * dy - origin) * scale
            if (  # a grid step of margin: rounding cannot take a tap outside
                1 <= min(u_first, u_last)
                and max(u_first, u_last) < width - 2
                and 1 <= min(v_first, v_last)
                and max(v_first, v_last) < height - 2
            ):
                _coarse_interior(ix, iy, xk, yk, dx, dy, steps, origin, scale, values)
            else:
                for i in range(steps.size):
                    values[i] = _gradient_squared(
                        ix,
                        iy,
                        (xk + steps[i] * dx - origin) * scale,
                        (yk + steps[i] * dy - origin) * scale,
                    )
            best = -1.0
            at = 0
            for i in range(steps.size):
                if values[i] > best:
                    best = values[i]
                    at = i
            if at == 0 or at == steps.size - 1:
                out[side, k] = np.nan
                continue
            distance = steps[at]
            u_first = (xk + (distance - 2 * REFINE_STEP_PX) * dx - origin) * scale
            v_first = (yk + (distance - 2 * REFINE_STEP_PX) * dy - origin) * scale
            u_last = (xk + (distance + 2 * REFINE_STEP_PX) * dx - origin) * scale
            v_last = (yk + (distance + 2 * REFINE_STEP_PX) * dy - origin) * scale
            inside = (  # taps span ⌊u⌋ − 1 … ⌊u⌋ + 2; a grid step of margin for rounding
                2 <= min(u_first, u_last)
                and max(u_first, u_last) < width - 3
                and 2 <= min(v_first, v_last)
                and max(v_first, v_last) < height - 3
            )
            if inside:
                for i in range(5):
                    step = distance + (i - 2) * REFINE_STEP_PX
                    u = (xk + step * dx - origin) * scale
                    v = (yk + step * dy - origin) * scale
                    refined[i] = _cubic_gradient_interior(ix, iy, u, v)
            else:
                for i in range(5):
                    step = distance + (i - 2) * REFINE_STEP_PX
                    u = (xk + step * dx - origin) * scale
                    v = (yk + step * dy - origin) * scale
                    taps = cubic_taps(u, v, height, width)
                    refined[i] = _magnitude(cubic_at(ix, *taps), cubic_at(iy, *taps))
            node = 0
            for i in range(1, 5):
                if refined[i] > refined[node]:
                    node = i  # the first maximum, as np.argmax
            node = min(max(node, 1), 3)
            left, mid, right = refined[node - 1], refined[node], refined[node + 1]
            curvature = left - 2 * mid + right
            shift = 0.5 * (left - right) / curvature if curvature < 0 else 0.0
            out[side, k] = distance + (node - 2 + min(max(shift, -1.0), 1.0)) * REFINE_STEP_PX


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
    The maxima are found on a bilinear profile, then refined on cubic samples.
    """
    steps = np.arange(1, int(np.ceil(reach_px / STEP_PX)) + 1) * STEP_PX
    d = level.derivatives
    x, y, nx, ny = (np.ascontiguousarray(a, np.float64) for a in (x, y, nx, ny))
    distances = np.empty((2, x.size))
    _edge_distances(d.ix, d.iy, level.stride, x, y, nx, ny, steps, distances)
    half = 0.5 * (distances[0] + distances[1])
    return 4 * np.sqrt(np.maximum(half**2 - level.sigma_px**2, 0))
