"""Glints beside the stripe, fitted and subtracted so that the stripe's centres can be read
again (adaptive, switchable, off by default: `extract_centres(glint_subtraction=True)`,
method label +glints).

A specular glint next to the stripe adds its light to one side of the stripe's
cross-section: where it outshines a dim stripe (the steep worn step of a flank on the
simulated clean passes) the cross-section holds no maximum of the stripe's own and the
centres there are lost or bent towards it (docs/extraction.md, "Glints touching the
stripe"). The glints are those the chain rules found as round spots (`line_test.is_spot`:
one per spot, the highest centre of its chain). Each is fitted as a round Gaussian on a
local background, b + A·exp(−r²/2s²), on the pixels within `FIT_REACH_PX` of it that the
stripe does not brighten: light only adds, so after each fit the pixels more than
`TRIM_NOISE` robust noise levels above the model (the stripe's) are left out and the fit
is repeated, at most `FIT_ROUNDS` times. Saturated pixels never enter the fit. The fitted
spot (not its background) is subtracted from the frame over ±4s, and the frame's centres
are extracted again on it.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import least_squares

FIT_REACH_PX = 14
"""Half-size of the square fitted about a glint [px]: 4s of the largest spot the chain
rules call round at the pipeline's scales (s ≤ 3.5 px)."""
FIT_ROUNDS = 5
TRIM_NOISE = 3.0
"""Pixels above the fitted spot by more than 3 robust noise levels (1.4826·MAD of the kept
residuals, plus 1 grey level) are the stripe's and leave the next round's fit."""
MERGE_PX = 3.0
"""Spot tops within 3 px of each other are one glint (a spot may hold several chains)."""
NEAR_STRIPE_PX = 32.0
"""Only glints whose chain top lies within 32 px of a centre the first extraction kept are
fitted: a spot of s ≤ 3.5 px adds under 0.1 grey level 4s = 14 px from its centre, the
stripe's edge lies ≤ 10.5 px (w/2) from its line, and where a glint cuts the stripe its
nearest kept centres are up to 20 px along the lost stretch from it (the clean passes'
overlays). Grain of a lit scene far from the stripe is left alone (on the field passes it
made the extraction 2.9× slower)."""
MAX_MOVE_PX = 4.0
SIGMA_RANGE_PX = (0.7, 8.0)
"""Bounds of the fit: the spot's centre within 4 px of its chain's top; its size s [px]."""


def merged(tops: np.ndarray) -> np.ndarray:
    """Spot tops (G, 3): x, y [px] and the chain's scale σ [px], with those within
    MERGE_PX of an earlier one dropped."""
    kept: list[np.ndarray] = []
    for top in tops:
        if all(math.dist(top[:2], other[:2]) > MERGE_PX for other in kept):
            kept.append(top)
    return np.array(kept).reshape(-1, 3)


def _spot(q: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """A·exp(−r²/2s²) with q = (A, cx, cy, s, b) [grey levels, px]."""
    return q[0] * np.exp(-((x - q[1]) ** 2 + (y - q[2]) ** 2) / (2 * q[3] ** 2))


def _residuals(q: np.ndarray, x: np.ndarray, y: np.ndarray, v: np.ndarray) -> np.ndarray:
    """b + A·exp(−r²/2s²) − v at the pixels (x, y) of grey v."""
    return q[4] + _spot(q, x, y) - v


def _jacobian(q: np.ndarray, x: np.ndarray, y: np.ndarray, _v: np.ndarray) -> np.ndarray:
    """∂(residual)/∂(A, cx, cy, s, b) at the pixels (x, y), shape (K, 5)."""
    dx, dy = x - q[1], y - q[2]
    g = np.exp(-(dx * dx + dy * dy) / (2 * q[3] ** 2))
    ag = q[0] * g
    return np.column_stack(
        [
            g,
            ag * dx / q[3] ** 2,
            ag * dy / q[3] ** 2,
            ag * (dx * dx + dy * dy) / q[3] ** 3,
            np.ones_like(g),
        ]
    )


def fit_glint(
    image: np.ndarray, x_px: float, y_px: float, sigma_px: float, full_scale: float
) -> np.ndarray:
    """(A, cx, cy, s, b) of the glint near (x_px, y_px) [grey levels, px, px, px, grey levels].

    Parameters
    ----------
    image : ndarray of shape (M, N)
        The frame [grey levels].
    x_px, y_px : float
        The glint's chain top [px].
    sigma_px : float
        The scale its chain was found at [px]: the fit starts at s = 0.7σ (at least 1 px).
    full_scale : float
        Saturated grey level: such pixels are left out of the fit.
    """
    height, width = image.shape
    r0, r1 = max(int(y_px) - FIT_REACH_PX, 0), min(int(y_px) + FIT_REACH_PX + 1, height)
    c0, c1 = max(int(x_px) - FIT_REACH_PX, 0), min(int(x_px) + FIT_REACH_PX + 1, width)
    patch = image[r0:r1, c0:c1].astype(np.float64)
    yy, xx = np.mgrid[r0:r1, c0:c1].astype(np.float64)
    unsaturated = patch < full_scale - 0.5
    background = float(np.percentile(patch, 10))
    near = (xx - x_px) ** 2 + (yy - y_px) ** 2 <= 4.0
    peak = float(patch[near].max()) if near.any() else float(patch.max())
    q = np.array([max(peak - background, 1.0), x_px, y_px, max(0.7 * sigma_px, 1.0), background])
    lower = [0.0, x_px - MAX_MOVE_PX, y_px - MAX_MOVE_PX, SIGMA_RANGE_PX[0], -full_scale]
    upper = [4 * full_scale, x_px + MAX_MOVE_PX, y_px + MAX_MOVE_PX, SIGMA_RANGE_PX[1], full_scale]
    used = unsaturated
    for _ in range(FIT_ROUNDS):
        pixels = (xx[used], yy[used], patch[used])
        q = least_squares(_residuals, q, jac=_jacobian, bounds=(lower, upper), args=pixels).x
        residual = patch - q[4] - _spot(q, xx, yy)
        noise = 1.4826 * float(np.median(np.abs(residual[used]))) + 1.0
        trimmed = unsaturated & (residual < TRIM_NOISE * noise)
        if np.array_equal(trimmed, used):
            break
        used = trimmed
    return q


def near_stripe(tops: np.ndarray, stripe_xy: np.ndarray) -> np.ndarray:
    """The tops (G, 3) within NEAR_STRIPE_PX of a point of `stripe_xy` (K, 2) [px]."""
    if not tops.size or not stripe_xy.size:
        return tops[:0]
    d2 = ((tops[:, None, :2] - stripe_xy[None, :, :]) ** 2).sum(axis=2)
    return tops[d2.min(axis=1) <= NEAR_STRIPE_PX**2]


def without_glints(
    image: np.ndarray, tops: np.ndarray, full_scale: float, stripe_xy: np.ndarray
) -> np.ndarray | None:
    """The frame (float32, grey levels ≥ 0) with the glints at `tops` (G, 3: x, y, σ [px];
    `merged`) near the stripe's centres `stripe_xy` (K, 2) [px] (`near_stripe`) fitted
    (`fit_glint`) and subtracted over ±4s; None when no glint is near the stripe."""
    tops = near_stripe(merged(tops), stripe_xy)
    if not tops.size:
        return None
    out = image.astype(np.float32)
    height, width = image.shape
    for x_px, y_px, sigma_px in tops:
        q = fit_glint(image, float(x_px), float(y_px), float(sigma_px), full_scale)
        reach = int(math.ceil(4 * q[3])) + 1
        r0, r1 = max(int(q[2]) - reach, 0), min(int(q[2]) + reach + 1, height)
        c0, c1 = max(int(q[1]) - reach, 0), min(int(q[1]) + reach + 1, width)
        yy, xx = np.mgrid[r0:r1, c0:c1].astype(np.float64)
        out[r0:r1, c0:c1] -= _spot(q, xx, yy).astype(np.float32)
    np.clip(out, 0.0, None, out=out)
    return out
