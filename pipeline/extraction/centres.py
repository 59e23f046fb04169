"""Stripe centres of a frame: the `Centres` result and `extract_centres`, the design's contract.

The method, its equations and constants: docs/extraction.md.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, fields, replace

import numpy as np
from scipy.spatial import cKDTree

from pipeline.extraction.adaptive import (
    LevelResponse,
    choose_in_band,
    choose_scales,
    lines_at,
    stripe_scales,
)
from pipeline.extraction.asymmetry import asymmetry_bias, peak_offsets
from pipeline.extraction.band_analysis import analyse_band, analyse_fixed_scale
from pipeline.extraction.blocks import all_blocks
from pipeline.extraction.classic import segment_classic
from pipeline.extraction.components import band_pixels
from pipeline.extraction.curvature import (
    LocalFits,
    local_curvature,
    local_fits,
    remove_curvature_bias,
    smooth_along,
)
from pipeline.extraction.gaps import bridge_gaps
from pipeline.extraction.gaussian import MIN_SIGMA_PX
from pipeline.extraction.glints import without_glints
from pipeline.extraction.line_test import (
    chain_tops,
    is_line,
    line_profiles,
    on_bodies,
    spot_chains,
)
from pipeline.extraction.linking import NEIGHBOUR_REACH_PX, link_points
from pipeline.extraction.normal_fit import matched_offsets
from pipeline.extraction.ridges import RIDGE_C_FULL_SCALE
from pipeline.extraction.scalespace import ScaleLevel
from pipeline.extraction.segmentation import (
    CHAIN_FRACTION,
    CHAIN_MIN_POINTS,
    CHAIN_WIDTH_FACTOR,
    CONTINUITY_GAP_PX,
    STRONG_C_RATIO,
    chain_ends,
    chain_maxima,
    longest_lines,
)
from pipeline.extraction.steger import centre_pixels, newton_step
from pipeline.extraction.widths import stripe_widths
from pipeline.imaging import GEOMETRY_FLOAT, PixelRegion, validate_image

METHODS = ("adaptive", "steger", "classic")
"""Extraction methods of `extract_centres`."""

ALONG_SUPPORT = 0.7
"""Base support of the along-stripe fit of matched centres, in units of the scale matching
the stripe's width (w/√3): on the exact-truth wheel stripe 0.7 keeps the clean RMS at
0.003 px (1.0: 0.006 px, the quadratic fit's error where the curvature changes), and the
scatter-chosen support widens it up to 3× where the centres scatter."""

KERNEL_FACTORS = (1.0, 2.0)
"""Matched-kernel scales tried across the stripe, in units of the profile's s: 1 is the
matched filter (additive noise), 2 ≈ the σ = w/√3 of the scale choice, which weights the
flanks (noise proportional to the stripe: texture, speckle)."""

END_POINTS = 8
"""Centres at each end of a polyline whose normal is taken from the polyline's interior
(`_end_normals`): over the last ~8 centres of a piece the Hessian's normal tilts by up to
14° where the stripe fades or stops (docs/extraction.md, "Centres at a piece's end")."""

END_FIT_POINTS = 16
"""Interior centres whose quadratic fit gives the end centres' normals; at each end of a
polyline of fewer than END_FIT_POINTS + 2·END_POINTS centres as many as it has beyond
END_FIT_POINTS, halved (none under END_FIT_POINTS + 2)."""

PRE_FIT_ROUNDS = 1
"""Curvature fits (`curvature.remove_curvature_bias`, rounds) that free the centres of
their curvature bias before the matched fit. The matched centres have none of their own
and are fitted along the stripe afresh (`curvature.smooth_along`); the bias removal only
places the normals' reads and keeps an unbiased Steger centre where a matched fit fails, so
one round does (FIT_ROUNDS, 3, corrects the steps between neighbours found at different
scales): on every accuracy and field-harsh case the RMS moved by ≤ 0.0002 px but
saturated +0.0012 (0.0120 → 0.0132), lit-edge-crossing −0.0019 and field-all −0.0068 px,
the real frames' shares by ≤ 0.3 %, for 0.23–0.31 ms less per dark speed frame (2 rounds:
0.11–0.16 ms)."""

END_MOVES = 2
"""Matched steps (each ≤ MAX_MOVE_PX) that bring an end centre onto the maximum along its
new normal before the refinement: the Hessian centre lies up to ~1.3 px off the line."""


@dataclass(frozen=True, slots=True, eq=False)
class Centres:
    """Sub-pixel stripe centre points of one frame, ordered along linked polylines.

    Attributes
    ----------
    x, y : ndarray of shape (K,), float64
        Centre position [px]; x is the column, y the row, the centre of pixel [r, c] is (c, r).
    nx, ny : ndarray of shape (K,), float64
        Unit stripe normal (eigenvector of λ1), oriented consistently along each polyline.
    sigma : ndarray of shape (K,), float64
        Gaussian scale the point was extracted at [px] (σB for "adaptive").
    strength : ndarray of shape (K,), float64
        Scale-normalised line strength σ²|λ1| [grey levels of the input frame].
    width_px : ndarray of shape (K,), float64
        Stripe width: 1/e² full width of the equivalent Gaussian profile [px], NaN where
        an edge was not found within reach.
    mask : ndarray of shape (M, N), bool
        The stripe mask the centres were searched in.
    sigma_map : ndarray of shape (M, N), float32, or None
        σB [px] per mask pixel, 0 outside the mask and where no scale sees a bright line;
        None for the fixed-σ methods.
    polylines : tuple of ndarray of int64
        Linked polylines (Steger's linking), each an ordered index array into the point
        arrays. The polylines are contiguous, consecutive ranges covering every point:
        isolated points and chains shorter than 3 points are dropped from the result.
    method : str
        "adaptive", "steger" or "classic".
    sigmas_px : tuple of float
        Scales used: (σ1, σ2, σ3) for "adaptive", (σ,) for "steger" and "classic".
    path : str
        How the frame was analysed: "band" (inside the stripe band located on the coarsest
        scale, the camera-rate path), "wide band" (the same in a wider band, because a stripe
        component reached the first one's edge), "full" (the whole frame, the band of all
        blocks, asked for), or "fallback" (the whole frame because no band could be trusted
        for this frame).
    rejected_x, rejected_y : ndarray of shape (R,), float64
        Sub-pixel positions [px] of the candidate centres inside the mask that "adaptive"
        rejected: the line-vs-edge test's (`pipeline.extraction.line_test`: the grey does
        not fall off on both sides, or the line is thinner than width_min allows), those of
        chains that are round spots (`line_test.is_spot`), of a whole frame's long chains
        that are highlights on a lit body (`line_test.on_bodies`), of dim chains short or
        apart from the stripe (`segmentation.CHAIN_FRACTION`), of chains wider than the
        width range (`segmentation.CHAIN_WIDTH_FACTOR`) and, outside a search region, of
        lines far shorter than the longest (`segmentation.longest_lines`). Empty for
        "steger" and "classic", the paper's baselines.
    region : PixelRegion or None
        The part of the frame searched (None: all of it); nothing outside it is in the mask.

    All arrays are read-only.
    """

    x: np.ndarray
    y: np.ndarray
    nx: np.ndarray
    ny: np.ndarray
    sigma: np.ndarray
    strength: np.ndarray
    width_px: np.ndarray
    mask: np.ndarray
    sigma_map: np.ndarray | None
    polylines: tuple[np.ndarray, ...]
    method: str
    sigmas_px: tuple[float, ...]
    path: str
    rejected_x: np.ndarray
    rejected_y: np.ndarray
    region: PixelRegion | None = None

    def __post_init__(self) -> None:
        arrays = [self.x, self.y, self.nx, self.ny, self.sigma, self.strength, self.width_px]
        if len({a.shape for a in arrays}) != 1:
            raise ValueError("Centres point arrays must have equal lengths")
        if self.rejected_x.shape != self.rejected_y.shape:
            raise ValueError("Centres rejected_x and rejected_y must have equal lengths")
        rejected = [self.rejected_x, self.rejected_y]
        for array in [*arrays, *rejected, self.mask, self.sigma_map, *self.polylines]:
            if array is not None:
                array.flags.writeable = False

    def __len__(self) -> int:
        return int(self.x.size)


def _check_widths(width_min: float, width_max: float) -> None:
    for name, value in (("width_min", width_min), ("width_max", width_max)):
        if not isinstance(value, int | float) or not math.isfinite(value) or value <= 0:
            raise ValueError(f"{name} must be a positive number of px, got {value!r}")
    if width_min > width_max:
        raise ValueError(f"width_min must be ≤ width_max, got {width_min} > {width_max}")
    if width_min / math.sqrt(3) < MIN_SIGMA_PX:
        raise ValueError(
            f"width_min must be ≥ {MIN_SIGMA_PX * math.sqrt(3):.2f} px "
            f"(σ1 = width_min/√3 ≥ {MIN_SIGMA_PX}), got {width_min}"
        )


def _check_sigma(sigma: float | None, method: str) -> None:
    if sigma is None:
        return
    if method == "adaptive":
        raise ValueError(
            "sigma applies to the fixed-σ methods 'steger' and 'classic', not 'adaptive'"
        )
    if not isinstance(sigma, int | float) or not math.isfinite(sigma) or sigma < MIN_SIGMA_PX:
        raise ValueError(f"sigma must be a number ≥ {MIN_SIGMA_PX} px, got {sigma!r}")


def full_scale(dtype: np.dtype) -> float:
    """Full-scale grey level of a frame type: 65535 for uint16, else 255 (8-bit scale)."""
    return 65535.0 if dtype == np.uint16 else 255.0


@dataclass(frozen=True, slots=True, eq=False)
class _Selected:
    """Centre pixels with the line analysis they were accepted with; arrays (K,)."""

    rows: np.ndarray
    cols: np.ndarray
    sigma: np.ndarray
    strength: np.ndarray
    nx: np.ndarray
    ny: np.ndarray
    offset: np.ndarray
    level_index: np.ndarray
    levels: tuple[ScaleLevel, ...]
    lambda_ratio: np.ndarray


_CANDIDATE_ARRAYS = tuple(f.name for f in fields(_Selected) if f.name != "levels")
"""The per-candidate array fields of _Selected (all but the scale levels they share)."""


def _lambda_ratio(lambda1: np.ndarray, lambda2: np.ndarray) -> np.ndarray:
    """λ2/λ1 (float64): 1 on a round spot's centre, 0 on a straight line, negative where the
    grey curves up along the line; 0 where λ1 = 0 (no candidate there)."""
    lambda1 = lambda1.astype(np.float64)
    safe = np.where(lambda1 != 0, lambda1, 1.0)
    return np.where(lambda1 != 0, lambda2.astype(np.float64) / safe, 0.0)


def _select_adaptive(
    scales: tuple[LevelResponse, ...],
    sigmas_px: tuple[float, ...],
    mask: np.ndarray,
    blocks: np.ndarray,
) -> tuple[_Selected, np.ndarray]:
    """Centre pixels at σB, and the σ map (σB per mask pixel, exact at the candidates)."""
    sigma_map, rows, cols, index = choose_in_band(scales, sigmas_px, mask, blocks)
    choice = choose_scales(scales, rows, cols, index)
    lines = choice.lines
    ok = centre_pixels(rows, cols, lines, choice.strength, mask.shape)
    ok &= choice.scale_index >= 0
    index = choice.scale_index[ok]
    selected = _Selected(
        rows=rows[ok],
        cols=cols[ok],
        sigma=np.asarray(sigmas_px, GEOMETRY_FLOAT)[index],
        strength=choice.strength[ok],
        nx=lines.nx[ok],
        ny=lines.ny[ok],
        offset=lines.offset_px[ok],
        level_index=index,
        levels=tuple(scale.level for scale in scales),
        lambda_ratio=_lambda_ratio(lines.lambda1[ok], lines.lambda2[ok]),
    )
    return selected, sigma_map


def _select_fixed(scale: LevelResponse, mask: np.ndarray, blocks: np.ndarray) -> _Selected:
    rows, cols = band_pixels(mask & scale.hints, blocks)
    level = scale.level
    lines = lines_at(level, rows, cols)
    ok = centre_pixels(rows, cols, lines, -lines.lambda1, mask.shape)
    return _Selected(
        rows=rows[ok],
        cols=cols[ok],
        sigma=np.full(int(ok.sum()), level.sigma_px, GEOMETRY_FLOAT),
        strength=level.sigma_px**2 * -lines.lambda1[ok],
        nx=lines.nx[ok],
        ny=lines.ny[ok],
        offset=lines.offset_px[ok],
        level_index=np.zeros(int(ok.sum()), np.int64),
        levels=(level,),
        lambda_ratio=_lambda_ratio(lines.lambda1[ok], lines.lambda2[ok]),
    )


def _asymmetry(x, y, nx, ny, sigma, widths, polylines, levels, bias_sigma):
    """Asymmetry bias along n [px] of a maximum at scale `bias_sigma` (K,), measured from
    the move of the centres' maxima to the next smaller scale (the next larger one for the
    smallest)."""
    sigmas = np.array([level.sigma_px for level in levels])
    moves = np.full(x.size, np.nan)
    second = np.full(x.size, np.nan)
    for own in np.unique(sigma):
        smaller, larger = np.flatnonzero(sigmas < own), np.flatnonzero(sigmas > own)
        if smaller.size:  # the maximum moves most towards the true line at small scales
            other = smaller[np.argmax(sigmas[smaller])]
        elif larger.size:
            other = larger[np.argmin(sigmas[larger])]
        else:
            continue
        at = np.flatnonzero(sigma == own)
        moves[at] = peak_offsets(levels[other], x[at], y[at], nx[at], ny[at])
        second[at] = sigmas[other]
    # A curved stripe's maximum moves between scales too, by (σb² − σa²)·κ/2 towards its
    # centre of curvature: that part of the move is not asymmetry.
    for chain in polylines:
        kappa = local_curvature(x[chain], y[chain], nx[chain], ny[chain], sigma[chain])
        moves[chain] -= 0.5 * (second[chain] ** 2 - sigma[chain] ** 2) * kappa
    return asymmetry_bias(moves, sigma, second, widths, polylines, bias_sigma)


def _matched_sigma(sigma: np.ndarray, widths: np.ndarray) -> np.ndarray:
    """s of the matched kernel [px]: a quarter of the measured width (√3σ/4, the width σ
    matches, where none was measured)."""
    known = np.isfinite(widths) & (widths > 0)
    return np.where(known, widths / 4, math.sqrt(3) / 4 * sigma)


def _end_normals(x, y, nx, ny, polylines) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Normals of the END_POINTS centres at each polyline end from the quadratic
    v = a + b·u + c·u² fitted to the next END_FIT_POINTS centres, in the frame of the first
    of them, at each end centre's u; and which centres got one (bool).

    No end overlaps another end's fitted centres, so the ends are read all at once and only
    the fits run one by one."""
    nx, ny = nx.copy(), ny.copy()
    moved = np.zeros(x.size, bool)
    runs, ends = [], []
    for chain in polylines:
        count = min(END_POINTS, (chain.size - END_FIT_POINTS) // 2)
        if count < 1:
            continue
        for run in (chain, chain[::-1]):
            runs.append(run[count : count + END_FIT_POINTS])
            ends.append(run[:count])
    if not runs:
        return nx, ny, moved
    inner = np.array(runs)  # (R, END_FIT_POINTS)
    k = inner[:, :1]
    tx, ty = -ny[k], nx[k]
    u = (x[inner] - x[k]) * tx + (y[inner] - y[k]) * ty
    v = (x[inner] - x[k]) * nx[k] + (y[inner] - y[k]) * ny[k]
    fits = np.array([np.polyfit(a, b, 2) for a, b in zip(u, v, strict=True)])
    # Each end centre with its run's frame and fit.
    end = np.concatenate(ends)
    owner = np.repeat(np.arange(len(runs)), [e.size for e in ends])
    k, tx, ty = k[owner, 0], tx[owner, 0], ty[owner, 0]
    c, b = fits[owner, 0], fits[owner, 1]
    slope = b + 2 * c * ((x[end] - x[k]) * tx + (y[end] - y[k]) * ty)
    norm = np.hypot(1.0, slope)
    ex, ey = (nx[k] - slope * tx) / norm, (ny[k] - slope * ty) / norm
    sign = np.where(ex * nx[end] + ey * ny[end] < 0, -1.0, 1.0)
    nx[end], ny[end] = ex * sign, ey * sign
    moved[end] = True
    return nx, ny, moved


def _refine_on_normals(image, x, y, nx, ny, sigma, widths, polylines, asymmetry):
    """Centres refined by the matched profile fit (`normal_fit`), then smoothed along their
    polylines over the scatter-chosen support (`curvature.smooth_along`).

    The points are first freed of their curvature bias, so that a point whose matched fit
    fails keeps an unbiased Steger centre. Each polyline takes the kernel of
    KERNEL_FACTORS × s whose centres scatter least along it (σl, `local_fits`): s where
    the noise is additive, wider where texture or speckle multiplies the stripe (its noise
    is largest at the peak, and a wider kernel weights the flanks). `asymmetry(scale)`
    gives the asymmetry bias along n [px] of a maximum at that kernel scale (None: none).
    The base support along the stripe is ALONG_SUPPORT × the scale matching the width, at
    least σ. The centres near each polyline end are first read along the normal of the
    polyline's interior (`_end_normals`) and moved onto the matched maximum there.
    Returns the centres and their normals.
    """
    s = _matched_sigma(sigma, widths)
    nx, ny, ends = _end_normals(x, y, nx, ny, polylines)
    x, y = x.astype(GEOMETRY_FLOAT, copy=True), y.astype(GEOMETRY_FLOAT, copy=True)
    for _ in range(END_MOVES):
        t = matched_offsets(image, x[ends], y[ends], nx[ends], ny[ends], s[ends], (1.0,))[0]
        t = np.where(np.isfinite(t), t, 0.0)
        x[ends] += t * nx[ends]
        y[ends] += t * ny[ends]
    x, y = remove_curvature_bias(x, y, nx, ny, sigma, polylines, rounds=PRE_FIT_ROUNDS)
    support = ALONG_SUPPORT * np.maximum(sigma, 4 * s / math.sqrt(3))
    best = np.zeros(x.size)
    least = np.full(x.size, np.inf)
    fitted, count = np.zeros(x.size), np.zeros(x.size)
    offsets = matched_offsets(image, x, y, nx, ny, s, KERNEL_FACTORS)
    for factor, t in zip(KERNEL_FACTORS, offsets, strict=True):
        if asymmetry is not None:
            t = t - asymmetry(factor * s)
        t = np.where(np.isfinite(t), t, 0.0)
        fits = local_fits(x + t * nx, y + t * ny, nx, ny, support, polylines)
        better = fits.scatter < least  # one σl per polyline: a whole polyline's choice
        best[better], least[better] = t[better], fits.scatter[better]
        fitted[better], count[better] = fits.offset[better], fits.count[better]
    # The chosen kernel's fits are those of the centres smoothed below (polylines whose σl
    # is NaN kept their Steger centres and are fitted anew).
    chosen = None
    if polylines and np.isfinite(least[np.concatenate(polylines)]).all():
        chosen = LocalFits(offset=fitted, count=count, scatter=least)
    x, y = smooth_along(x + best * nx, y + best * ny, nx, ny, support, polylines, fits=chosen)
    return x, y, nx, ny


def _orient_normals(nx: np.ndarray, ny: np.ndarray, chains: list[np.ndarray]) -> None:
    """Flip normals in place so they turn smoothly along each chain; first one has ny ≥ 0."""
    for chain in chains:
        cx, cy = nx[chain], ny[chain]
        flips = np.ones(chain.size)
        flips[1:] = np.where(cx[1:] * cx[:-1] + cy[1:] * cy[:-1] < 0, -1.0, 1.0)
        sign = np.cumprod(flips)
        if cy[0] < 0 or (cy[0] == 0 and cx[0] < 0):
            sign = -sign
        nx[chain] = cx * sign
        ny[chain] = cy * sign


def _subpixel(selected: _Selected) -> tuple[np.ndarray, ...]:
    """Sub-pixel centres x, y and normals nx, ny (float64) of the selected pixels."""
    nx = selected.nx.astype(GEOMETRY_FLOAT)
    ny = selected.ny.astype(GEOMETRY_FLOAT)
    offset = selected.offset.astype(GEOMETRY_FLOAT)
    x = selected.cols + offset * nx  # paper eq. (9)
    y = selected.rows + offset * ny
    for i, level in enumerate(selected.levels):
        at = np.flatnonzero(selected.level_index == i)
        if not at.size:
            continue
        step = newton_step(level, x[at], y[at], nx[at], ny[at])
        x[at] += step * nx[at]
        y[at] += step * ny[at]
    return x, y, nx, ny


def _subset(selected: _Selected, which: np.ndarray) -> _Selected:
    """The candidates `which` (bool or index array) of `selected`."""
    return _Selected(
        **{name: getattr(selected, name)[which] for name in _CANDIDATE_ARRAYS},
        levels=selected.levels,
    )


def _joined(a: _Selected, b: _Selected) -> _Selected:
    """The candidates of `a` followed by those of `b` (the same scale levels)."""
    return _Selected(
        **{
            name: np.concatenate([getattr(a, name), getattr(b, name)]) for name in _CANDIDATE_ARRAYS
        },
        levels=a.levels,
    )


def _finer(selected: _Selected, failed: np.ndarray, shape: tuple[int, int]) -> _Selected:
    """The pixels around the candidates `failed` found above the smallest scale, analysed
    at the next smaller scale: those holding a centre there and no passing candidate."""
    at = np.flatnonzero(failed & (selected.level_index > 0))
    parts = [_subset(selected, np.zeros(0, np.int64))]
    if not at.size:
        return parts[0]
    step = np.array([-1, 0, 1])
    rows = (selected.rows[at, None, None] + step[:, None]).clip(0, shape[0] - 1)
    cols = (selected.cols[at, None, None] + step[None, :]).clip(0, shape[1] - 1)
    pixel = (rows * shape[1] + cols).reshape(at.size, 9)
    level = np.repeat(selected.level_index[at] - 1, 9)
    # Each pixel once, at the largest scale asked of it, unless a candidate passed there.
    order = np.lexsort((-level, pixel.ravel()))
    pixel, level = pixel.ravel()[order], level[order]
    first = np.concatenate(([True], pixel[1:] != pixel[:-1]))
    pixel, level = pixel[first], level[first]
    passed = selected.rows[~failed] * shape[1] + selected.cols[~failed]
    # Both sets hold each pixel once; a sort, not a table spanning the frame's pixels.
    free = ~np.isin(pixel, passed, assume_unique=True, kind="sort")
    pixel, level = pixel[free], level[free]
    for i in np.unique(level):
        pick = pixel[level == i]
        rows, cols = pick // shape[1], pick % shape[1]
        scale = selected.levels[i]
        lines = lines_at(scale, rows, cols)
        strength = scale.sigma_px**2 * -lines.lambda1
        ok = centre_pixels(rows, cols, lines, strength, shape)
        parts.append(
            _Selected(
                rows=rows[ok],
                cols=cols[ok],
                sigma=np.full(int(ok.sum()), scale.sigma_px, GEOMETRY_FLOAT),
                strength=strength[ok],
                nx=lines.nx[ok],
                ny=lines.ny[ok],
                offset=lines.offset_px[ok],
                level_index=np.full(int(ok.sum()), i, np.int64),
                levels=selected.levels,
                lambda_ratio=_lambda_ratio(lines.lambda1[ok], lines.lambda2[ok]),
            )
        )
    return functools.reduce(_joined, parts)


def _tested(image, selected: _Selected, width_min: float, c_grey: float):
    """Sub-pixel centres (x, y, nx, ny), line-test profiles and verdicts of `selected`."""
    x, y, nx, ny = _subpixel(selected)
    profiles = line_profiles(
        image, x, y, nx, ny, selected.sigma, width_min_px=width_min, c_grey=c_grey
    )
    return (x, y, nx, ny), profiles[2], is_line(profiles)


def _lines_only(
    image: np.ndarray, selected: _Selected, width_min: float | None, c_grey: float
) -> tuple[_Selected, tuple[np.ndarray, ...], np.ndarray, np.ndarray, np.ndarray]:
    """The candidates that are bright lines (`line_test.is_line`; all when `width_min` is
    None), their sub-pixel centres, normals and heights above the brighter side [grey
    levels; NaN when not tested], and the rejected ones' centres (x, y). `c_grey` is the
    ridge response's structure constant [grey levels].

    Where a candidate found above the smallest scale fails, the pixels around it are tried
    again at the next smaller scale (`_finer`): the ridge-peak strength that chooses σB is
    max-filtered over width_max/2, so where a narrow piece of a broken stripe starts beside
    a wide piece's end the wide piece's scale wins there, and the narrow line's centre at
    that scale is pulled towards the wide end (0.8 px on `broken-steps`) and fails the
    shoulder test. The rejected centres are those at σB."""
    if width_min is None:
        none = np.zeros(0)
        return selected, _subpixel(selected), np.full(selected.rows.size, np.nan), none, none
    points, height, line = _tested(image, selected, width_min, c_grey)
    finer = _finer(selected, ~line, image.shape)
    more, more_height, more_line = _tested(image, finer, width_min, c_grey)
    kept = _joined(_subset(selected, line), _subset(finer, more_line))
    xyn = tuple(np.concatenate([a[line], b[more_line]]) for a, b in zip(points, more, strict=True))
    heights = np.concatenate([height[line], more_height[more_line]])
    return kept, xyn, heights, points[0][~line], points[1][~line]


CONTINUING_MIN_POINTS = 8
"""Least centres of a dim chain kept because it continues a kept one (inside a search
region): about 1 mm of profile, the shortest piece measurement uses
(`pipeline.profile.measurement.MIN_WINDOW_CHAIN_POINTS`)."""
CONTINUING_COS = 0.8
"""A dim chain continues a kept one when the gap between their ends and the dim chain's
end direction both lie within 37° (cos 0.8) of the kept chain's direction at its end."""
CONTINUING_OFFSET_PX = 3.0
"""... and the dim chain's end lies within 3 px of the kept chain's line ahead of its end
(a flank bends by < 1 px over the 16 px gap; a piece of outline or ghost beside the
stripe is offset by more)."""
CONTINUING_TOUCH_PX = NEIGHBOUR_REACH_PX * math.sqrt(2.0)
"""... or, when the two ends lie within the linker's reach of each other (its 5×5
neighbourhood, 2.8 px), lies anywhere within CONTINUING_OFFSET_PX of it: the linker split
one line there (a texture-bent centre turned the normal by more than it links, or two
pieces overlap by a pixel), so the gap between the ends (0.3–2.8 px, often beside or
behind the kept end) has no direction of its own, and judging it by the 37° cone rejected
a harsh flank's dim pieces that continue the kept chain end to end."""


def _continuing(
    kept: list[bool], chains: list[np.ndarray], x: np.ndarray, y: np.ndarray
) -> list[bool]:
    """`kept` grown by the dim chains of ≥ CONTINUING_MIN_POINTS that continue a kept chain:
    an end within CONTINUITY_GAP_PX of a kept chain's end, ahead of it on its line (or
    touching it, `CONTINUING_TOUCH_PX`) and heading on (`CONTINUING_COS`,
    `CONTINUING_OFFSET_PX`), until none is added. A dimmed
    stretch of the laser (a polished flank next to its glare) is linked apart from its
    bright neighbours and is short; texture ridges and outlines beside the stripe lie
    beside its chains, not ahead of their ends."""
    ends = chain_ends(x, y, chains)
    kept_ends = np.repeat(np.asarray(kept, bool), 2)
    long_enough = np.repeat([c.size >= CONTINUING_MIN_POINTS for c in chains], 2)
    while True:
        dim = np.flatnonzero(~kept_ends & long_enough)
        held = np.flatnonzero(kept_ends)
        if dim.size == 0 or held.size == 0:
            break
        grown = np.unique(dim[_continues(ends[dim], ends[held]).any(axis=1)] // 2)
        if grown.size == 0:
            break
        kept_ends[2 * grown] = kept_ends[2 * grown + 1] = True
    return kept_ends[::2].tolist()


def _continues(dim: np.ndarray, held: np.ndarray) -> np.ndarray:
    """Which chain ends `dim` (D, 4) continue which ends `held` (H, 4) (rows x, y, tx, ty of
    `chain_ends`): bool (D, H), within CONTINUITY_GAP_PX ahead of the held end (or touching
    it), within CONTINUING_OFFSET_PX of its line and heading back against it.

    Only the pairs of ends within the gap (two k-d trees, their radius a hair wider) are
    tested: a lit frame has hundreds of chains, and the (D, H) float temporaries of every
    pair cost more than the rest of the chain selection. The pairs come as arrays
    (`sparse_distance_matrix`), not a list per end (~2,500 pairs of ~700 ends)."""
    out = np.zeros((dim.shape[0], held.shape[0]), bool)
    if out.size == 0:
        return out
    near = cKDTree(dim[:, :2]).sparse_distance_matrix(
        cKDTree(held[:, :2]), CONTINUITY_GAP_PX + _GAP_SLACK_PX, output_type="ndarray"
    )
    if near.size == 0:
        return out
    d, h = near["i"].astype(np.int64), near["j"].astype(np.int64)
    gap = dim[d, :2] - held[h, :2]
    direction = held[h, 2:]
    length = np.hypot(gap[:, 0], gap[:, 1])
    along = np.einsum("pk,pk->p", gap, direction)
    across = np.abs(gap[:, 0] * direction[:, 1] - gap[:, 1] * direction[:, 0])
    heading = np.einsum("pk,pk->p", dim[d, 2:], held[h, 2:]) <= -CONTINUING_COS
    ahead = (along >= CONTINUING_COS * length) | (length <= CONTINUING_TOUCH_PX)
    out[d, h] = (length <= CONTINUITY_GAP_PX) & ahead & (across <= CONTINUING_OFFSET_PX) & heading
    return out


_GAP_SLACK_PX = 1e-6
"""Widening of the k-d tree's radius over CONTINUITY_GAP_PX [px], so that no pair within the
gap by `np.hypot` is missed by the tree's own rounding of the distance."""


def _bridging(
    kept: list[bool], eligible: list[bool], chains: list[np.ndarray], xy: np.ndarray
) -> list[bool]:
    """`kept` grown by the `eligible` chains of ≥ CONTINUING_MIN_POINTS lying in a gap of a
    kept line: each of their two ends continues (`_continues`) an end of a kept chain or of
    another such chain, one of them a kept one's, until none is added. A piece of the stripe
    between two bright stretches (a laser line dimmed over a dark square of a printed board,
    linked apart from its bright pieces over the white ones) continues the line at both ends;
    a flare streak or a bent outline leaving the stripe continues it at one end only."""
    ends = chain_ends(xy[:, 0], xy[:, 1], chains)
    kept_chain = np.asarray(kept, bool)
    open_chain = ~kept_chain & np.asarray(eligible, bool)
    open_chain &= np.array([c.size >= CONTINUING_MIN_POINTS for c in chains], bool)
    joins = _continues(ends, ends)
    owner = np.repeat(np.arange(len(chains)), 2)
    joins &= owner[:, None] != owner[None, :]
    while open_chain.any():
        to_kept = np.any(joins[:, np.repeat(kept_chain, 2)], axis=1)
        to_line = to_kept | np.any(joins[:, np.repeat(open_chain, 2)], axis=1)
        bridge = open_chain & to_line[::2] & to_line[1::2] & (to_kept[::2] | to_kept[1::2])
        if not bridge.any():
            break
        kept_chain |= bridge
        open_chain &= ~bridge
    return kept_chain.tolist()


FORK_REACH_PX = 2.0 * CONTINUING_TOUCH_PX
"""A short chain forks off the stripe where an end of it lies within this distance [px] of
both ends at which two other kept chains continue each other (5.7 px: the two ends of a
stripe split at a glint lie up to 3 px apart, the third chain's end a little further)."""


def _forks(kept: list[bool], chains: list[np.ndarray], xy: np.ndarray) -> list[bool]:
    """`kept` without the short chains (< CHAIN_MIN_POINTS) that fork off a kept line: one
    of their ends lies within FORK_REACH_PX of two ends at which two other kept chains
    continue each other (`_continues`), and it continues neither. A laser line does not
    fork; a specular spot touching the stripe splits its chain there and adds a chain
    through the spot's side that runs off the line (a clean flank near the flange top: 18
    centres 1-2.6 mm outside the outline, docs/simulator.md). Only ends within the reach of
    each other are compared (a k-d tree): a real frame keeps up to ~200 chains."""
    if sum(kept) < 3:  # a fork needs two chains continuing each other and a third
        return kept
    held = np.flatnonzero(np.repeat(np.asarray(kept, bool), 2))
    ends = chain_ends(xy[:, 0], xy[:, 1], chains)[held]
    owner = held // 2
    joins = _continues(ends, ends) & (owner[:, None] != owner[None, :])
    joins |= joins.T
    a, b = np.nonzero(np.triu(joins))
    if a.size == 0:
        return kept
    tree = cKDTree(ends[:, :2])
    near = tree.sparse_distance_matrix(tree, FORK_REACH_PX, output_type="ndarray")
    close = np.zeros(joins.shape, bool)
    close[near["i"], near["j"]] = True
    short = np.array([chains[i].size < CHAIN_MIN_POINTS for i in owner])
    # (ends, junctions): an end near both of a junction's ends, continuing neither
    fork = close[:, a] & close[:, b] & ~joins[:, a] & ~joins[:, b]
    fork &= (owner[:, None] != owner[a]) & (owner[:, None] != owner[b]) & short[:, None]
    result = list(kept)
    for i in owner[fork.any(axis=1)]:
        result[i] = False
    return result


def _grown_near(
    kept: list[bool], chains: list[np.ndarray], long: list[bool], xy: np.ndarray
) -> list[bool]:
    """`kept` grown by the `long` chains with a centre within CONTINUITY_GAP_PX of a kept
    chain's, until none is added; `xy` (K, 2) are the centres [px]."""
    while any(kept):
        open_chains = [i for i, (k, g) in enumerate(zip(kept, long, strict=True)) if g and not k]
        if not open_chains:
            break
        near = cKDTree(xy[np.concatenate([c for c, k in zip(chains, kept, strict=True) if k])])
        # One query for the centres of every open chain, not one per chain.
        points = np.concatenate([chains[i] for i in open_chains])
        reached = near.query(xy[points], distance_upper_bound=CONTINUITY_GAP_PX)[0] < np.inf
        sizes = np.array([chains[i].size for i in open_chains])
        hits = np.logical_or.reduceat(reached, np.cumsum(sizes) - sizes).tolist()
        grown = list(kept)
        for i, hit in zip(open_chains, hits, strict=True):
            grown[i] = hit
        if grown == kept:
            break
        kept = grown
    return kept


def _bright_chains(
    chains: list[np.ndarray],
    height: np.ndarray,
    strength: np.ndarray,
    xy: np.ndarray,
    c_grey: float,
    continuing: bool = False,
) -> tuple[list[np.ndarray], np.ndarray]:
    """The chains of the stripe (`segmentation`; every chain when the heights are NaN) and
    the points of the others.

    A chain is kept when its highest line (`height` [grey levels]) is at least
    CHAIN_FRACTION of the highest chain's; a dimmer one only when it is long
    (≥ CHAIN_MIN_POINTS) and either strong in itself (`strength` up to STRONG_C_RATIO·c) or
    within CONTINUITY_GAP_PX of a kept chain (a dim stretch of the stripe beside its bright
    parts, not a flare streak or an outline apart from them), until none is added; a short
    one strong in itself when it lies in a gap of a kept line, continuing it at both ends
    (`_bridging`). With
    `continuing` (inside a search region, where the calibration says the stripe lies) every
    long chain is kept (a clean wheel's dim flank can lie further than CONTINUITY_GAP_PX from
    its tread's chain) and a short dim chain that continues a kept one too (`_continuing`).
    `xy` (K, 2) are the centres [px].
    """
    if not chains or np.isnan(height).all():
        return chains, np.zeros(0, np.int64)
    highest = chain_maxima(height, chains).tolist()
    least = CHAIN_FRACTION * max(highest)
    long = [c.size >= CHAIN_MIN_POINTS for c in chains]
    bright_enough = [h >= least for h in highest]
    if continuing:
        kept = [b or g for b, g in zip(bright_enough, long, strict=True)]
        if not all(kept):
            kept = _continuing(kept, chains, xy[:, 0], xy[:, 1])
    else:
        strong = (chain_maxima(strength, chains) >= STRONG_C_RATIO * c_grey).tolist()
        kept = [b or (g and t) for b, g, t in zip(bright_enough, long, strong, strict=True)]
        kept = _grown_near(kept, chains, long, xy)
        if not all(kept):
            kept = _bridging(kept, strong, chains, xy)
    kept = _forks(kept, chains, xy)
    dim = [c for c, k in zip(chains, kept, strict=True) if not k]
    bright = [c for c, k in zip(chains, kept, strict=True) if k]
    return bright, np.concatenate(dim) if dim else np.zeros(0, np.int64)


def _no_spots(
    chains: list[np.ndarray], height: np.ndarray, selected: _Selected, xy: np.ndarray
) -> tuple[list[np.ndarray], np.ndarray]:
    """The chains that are not round spots (`line_test.spot_chains`; every chain when the
    heights are NaN, the baselines) and the points of those that are. A spot's chain that continues
    another chain's line (`_continuing`) is the stripe's own, through a glint on it: where
    the stripe is faint or textured its chain breaks at the glint, and the piece holding the
    glint is short and highest there. `xy` (K, 2) are the centres [px]."""
    if not chains or np.isnan(height).all():
        return chains, np.zeros(0, np.int64)
    kept = (~spot_chains(xy, height, selected.lambda_ratio, selected.sigma, chains)).tolist()
    if not all(kept):
        kept = _continuing(kept, chains, xy[:, 0], xy[:, 1])
    spots = [c for c, k in zip(chains, kept, strict=True) if not k]
    lines = [c for c, k in zip(chains, kept, strict=True) if k]
    return lines, np.concatenate(spots) if spots else np.zeros(0, np.int64)


BODY_STEP = 2
"""The body test (`line_test.on_bodies`, a majority of a chain's centres) reads every
BODY_STEP-th centre of a chain from both its ends (`every_from_both_ends`): a lit body's
highlight runs along it for 130–160 centres (the real frames), so half of them decide
alike. Every accuracy and field-harsh case and real frame unchanged, 0.33–0.34 → 0.19–0.21
ms least per dark speed frame."""


def _off_bodies(image, chains, height, x, y, nx, ny, width_at, continuing):
    """The chains that are not highlights on a lit body (`line_test.on_bodies`) and the
    points of those that are; `width_at` the measured widths [px] of every point (NaN:
    none).

    Only a whole frame's chains of ≥ CHAIN_MIN_POINTS centres are judged: a lit body's
    highlight runs along the body (132–161 centres on the real frames). Next to a glare on
    the stripe the bloom around it raises the shoulders of the stripe's own pieces too
    (simulated harsh passes: 26–48 chains a pass, 6–54 centres each); inside a search region
    (`continuing`), where the calibration says the stripe lies, every chain is kept, as
    are the baselines' (NaN heights).
    """
    if continuing or not chains or np.isnan(height).all():
        return chains, np.zeros(0, np.int64)
    judged = [i for i, c in enumerate(chains) if c.size >= CHAIN_MIN_POINTS]
    on_body = np.zeros(len(chains), bool)
    on_body[judged] = on_bodies(
        image,
        x,
        y,
        nx,
        ny,
        width_at,
        [chains[i][every_from_both_ends(chains[i].size, BODY_STEP)] for i in judged],
    )
    kept = (~on_body).tolist()
    bodies = [c for c, k in zip(chains, kept, strict=True) if not k]
    lines = [c for c, k in zip(chains, kept, strict=True) if k]
    return lines, np.concatenate(bodies) if bodies else np.zeros(0, np.int64)


def _widths(levels, level_index, x, y, nx, ny, width_max: float) -> np.ndarray:
    """Stripe width [px] at centres (x, y) found at `levels[level_index]`
    (`widths.stripe_widths`, searched within twice the standard deviation of the widest
    stripe smoothed at that scale); NaN where an edge lies beyond reach."""
    widths = np.full(x.size, np.nan)
    for i, level in enumerate(levels):
        at = np.flatnonzero(level_index == i)
        if at.size:
            reach = 2 * math.hypot(level.sigma_px, width_max / 4) + 1
            widths[at] = stripe_widths(level, x[at], y[at], nx[at], ny[at], reach_px=reach)
    return widths


WIDTH_STEP = 3
"""Widths are measured on every WIDTH_STEP-th centre of each chain from both its ends; the
centres between take them linearly interpolated by index (measured themselves where a
neighbour found none). Centres lie ≈ 1 px apart and a stripe's width changes over tens of
px, so the chain rules (`_off_bodies`, `_narrow_chains`) and the matched kernel's s see the
same widths to within their noise: on every accuracy and field-harsh case the RMS moved by
≤ 0.0001 px but field-all's +0.006 (3 %), the real frames' on-line and coverage shares by
≤ 0.4 %, for ≈ 0.65 ms less per dark speed frame (the widths 1.24–1.29 → 0.56–0.63 ms
least; step 2: 0.76–0.83 ms, step 4 lost charuco-dim's on-line share 47.0 → 43.6 %;
docs/extraction.md §7, "Less work per frame")."""


def every_from_both_ends(size: int, step: int) -> np.ndarray:
    """Positions 0 … size − 1 of a chain taken every `step` from its first point over its
    first half and from its last point over its second half (both ends always): the same
    points whichever way the chain runs, so a flipped or transposed frame measures the same
    centres (tests/pipeline/test_properties.py)."""
    pos = np.arange(size)
    half = pos <= (size - 1) // 2
    return np.flatnonzero(np.where(half, pos % step == 0, (size - 1 - pos) % step == 0))


def _chain_widths(levels, level_index, x, y, nx, ny, chains, width_max: float) -> np.ndarray:
    """`_widths` of the chains' points (x, y, ... the chains' points in order), measured on
    every WIDTH_STEP-th centre of each chain from both its ends (`every_from_both_ends`),
    linearly interpolated by index between them (measured where a neighbour found none)."""
    if WIDTH_STEP == 1 or not chains:
        return _widths(levels, level_index, x, y, nx, ny, width_max)
    sizes = [c.size for c in chains]
    starts = np.cumsum([0] + sizes[:-1])
    at = np.concatenate(
        [
            start + every_from_both_ends(size, WIDTH_STEP)
            for start, size in zip(starts, sizes, strict=True)
        ]
    )
    out = np.full(x.size, np.nan)
    out[at] = _widths(levels, level_index[at], x[at], y[at], nx[at], ny[at], width_max)
    index = np.arange(x.size)
    measured = np.zeros(x.size, bool)
    measured[at] = True
    before = np.maximum.accumulate(np.where(measured, index, 0))
    after = np.minimum.accumulate(np.where(measured, index, x.size - 1)[::-1])[::-1]
    rest = np.flatnonzero(~measured)  # each chain's ends are measured: neighbours on its chain
    f = (rest - before[rest]) / (after[rest] - before[rest])
    out[rest] = (1 - f) * out[before[rest]] + f * out[after[rest]]
    again = rest[~np.isfinite(out[rest])]
    if again.size:
        out[again] = _widths(
            levels, level_index[again], x[again], y[again], nx[again], ny[again], width_max
        )
    return out


def _narrow_chains(
    chains: list[np.ndarray], widths: np.ndarray, width_max: float
) -> tuple[list[np.ndarray], np.ndarray]:
    """The chains whose measured widths (`widths`, the chains' points in order) are at most
    CHAIN_WIDTH_FACTOR·width_max at more than half of their points (`segmentation`; no
    width counts as wider), and which of the chains' points they hold (bool, same order)."""
    bounds = np.cumsum([0] + [c.size for c in chains])
    too_wide = ~(widths <= CHAIN_WIDTH_FACTOR * width_max)
    kept = np.zeros(widths.size, bool)
    narrow = []
    for chain, a, b in zip(chains, bounds[:-1], bounds[1:], strict=True):
        if too_wide[a:b].mean() <= 0.5:
            narrow.append(chain)
            kept[a:b] = True
    return narrow, kept


def _longest(chains: list[np.ndarray], xy: np.ndarray) -> tuple[list[np.ndarray], np.ndarray]:
    """The chains of the longest lines (`segmentation.longest_lines`) and which of the chains'
    points they hold (bool, the chains' points in order)."""
    keep = longest_lines(xy, chains)
    kept = np.repeat(keep, [c.size for c in chains])
    return [c for c, k in zip(chains, keep, strict=True) if k], kept


def _assemble(
    image: np.ndarray,
    candidates: _Selected,
    mask: np.ndarray,
    *,
    sigma_map: np.ndarray | None,
    method: str,
    sigmas_px: tuple[float, ...],
    width_min: float | None,
    width_max: float,
    curvature_correction: bool,
    scatter_support: bool,
    normal_fit: bool,
    second_levels: tuple[ScaleLevel, ...],
    path: str,
    c_grey: float,
    continuing: bool = False,
    gap_search: bool = False,
) -> tuple[Centres, np.ndarray]:
    """The centres of the candidates (`extract_centres`'s chain rules and refinement) and
    the spot chains' tops (`_spot_tops`)."""
    lines = _lines_only(image, candidates, width_min, c_grey)
    selected, (x, y, nx, ny), height, rejected_x, rejected_y = lines
    linked = link_points(selected.rows, selected.cols, x, y, nx, ny, selected.sigma, mask.shape)
    xy = np.column_stack([x, y])
    chains, spots = _no_spots(linked, height, selected, xy)
    spot_tops = _spot_tops(spots, height, selected.sigma, xy, linked)
    found = np.concatenate(chains) if chains else np.zeros(0, np.int64)
    width_at = np.full(x.size, np.nan)
    points = (x[found], y[found], nx[found], ny[found])
    width_at[found] = _chain_widths(
        selected.levels, selected.level_index[found], *points, chains, width_max
    )
    chains, bodies = _off_bodies(image, chains, height, x, y, nx, ny, width_at, continuing)
    chains, weak = _bright_chains(
        chains, height, selected.strength, xy, c_grey, continuing=continuing
    )
    rejected_x = np.concatenate([rejected_x, x[spots], x[bodies], x[weak]])
    rejected_y = np.concatenate([rejected_y, y[spots], y[bodies], y[weak]])
    _orient_normals(nx, ny, chains)
    order = np.concatenate(chains) if chains else np.zeros(0, np.int64)
    widths = width_at[order]
    if width_min is not None:
        chains, kept = _narrow_chains(chains, widths, width_max)
        wide = order[~kept]
        rejected_x = np.concatenate([rejected_x, x[wide]])
        rejected_y = np.concatenate([rejected_y, y[wide]])
        order, widths = order[kept], widths[kept]
        if not continuing:
            chains, kept = _longest(chains, xy)
            apart = order[~kept]
            rejected_x = np.concatenate([rejected_x, x[apart]])
            rejected_y = np.concatenate([rejected_y, y[apart]])
            order, widths = order[kept], widths[kept]
    sigma, strength = selected.sigma, selected.strength
    if gap_search and width_min is not None:
        bridges = bridge_gaps(image, x, y, sigma, chains, width_min_px=width_min, c_grey=c_grey)
        if bridges.chains:
            base = x.size
            x, y = np.concatenate([x, bridges.x]), np.concatenate([y, bridges.y])
            nx, ny = np.concatenate([nx, bridges.nx]), np.concatenate([ny, bridges.ny])
            sigma = np.concatenate([sigma, bridges.sigma])
            strength = np.concatenate([strength, bridges.strength])
            chains = chains + [base + c for c in bridges.chains]
            order = np.concatenate([order, base + np.concatenate(bridges.chains)])
            widths = np.concatenate([widths, np.full(bridges.x.size, np.nan)])
    bounds = np.cumsum([0] + [c.size for c in chains])
    polylines = tuple(
        np.arange(a, b, dtype=np.int64) for a, b in zip(bounds[:-1], bounds[1:], strict=True)
    )
    sigma = sigma[order].astype(GEOMETRY_FLOAT)
    x, y = x[order], y[order]
    asymmetry = None
    if second_levels:
        args = (x, y, nx[order], ny[order], sigma, widths, polylines, second_levels)
        asymmetry = functools.partial(_asymmetry, *args)
    nx, ny = nx[order], ny[order]
    if normal_fit:
        x, y, nx, ny = _refine_on_normals(image, x, y, nx, ny, sigma, widths, polylines, asymmetry)
    else:
        if asymmetry is not None:
            bias = asymmetry(sigma)
            x, y = x - bias * nx, y - bias * ny
        if curvature_correction or scatter_support:
            x, y = remove_curvature_bias(
                x, y, nx, ny, sigma, polylines, scatter_support=scatter_support
            )
    centres = Centres(
        x=x,
        y=y,
        nx=nx,
        ny=ny,
        sigma=sigma,
        strength=strength[order].astype(GEOMETRY_FLOAT),
        width_px=widths,
        mask=mask,
        sigma_map=sigma_map,
        polylines=polylines,
        method=method,
        sigmas_px=sigmas_px,
        path=path,
        rejected_x=rejected_x,
        rejected_y=rejected_y,
    )
    return centres, spot_tops


def _spot_tops(spots, height, sigma, xy, chains) -> np.ndarray:
    """(G, 3) x, y [px] and σ [px] of the highest centre of each chain of `spots` (the
    spot chains' points, from `_no_spots`), for `glints.without_glints`."""
    if not spots.size:
        return np.zeros((0, 3))
    held = np.zeros(xy.shape[0], bool)
    held[spots] = True
    tops = chain_tops(height, [c for c in chains if held[c[0]]])
    return np.column_stack([xy[tops], sigma[tops]])


def extract_centres(
    image: np.ndarray,
    method: str = "adaptive",
    width_min: float = 5,
    width_max: float = 21,
    sigma: float | None = None,
    *,
    curvature_correction: bool | None = None,
    asymmetry_correction: bool = False,
    scatter_support: bool = False,
    normal_fit: bool | None = None,
    gap_search: bool = False,
    glint_subtraction: bool = False,
    full_frame: bool = False,
    region: PixelRegion | None = None,
) -> Centres:
    """Extract the sub-pixel centre line of the bright laser stripe in a frame.

    Parameters
    ----------
    image : ndarray of shape (M, N), uint8 or uint16
        Grey frame. 16-bit frames are taken at full 16-bit scale (MSB-aligned). Finite float
        frames are accepted on the 8-bit grey scale (tests, simulators).
    method : {"adaptive", "steger", "classic"}
        "adaptive": the multi-scale adaptive method [2] — ridge-response segmentation, then per
        pixel the scale σB maximising σ²|λ1|, and Steger's sub-pixel step at σB.
        "steger": fixed-σ Steger [1] inside the same ridge-response mask (as the paper compares
        the two; the mask rejects stray spots and other parts' stripes for both).
        "classic": fixed-σ Steger inside the paper's baseline mask (median filter, Otsu,
        largest connected components).
    width_min, width_max : float
        Expected stripe width range [px], 0 < width_min ≤ width_max. They set the scales
        σ1 = wmin/√3, σ2 = (wmin+wmax)/(2√3), σ3 = wmax/√3.
    sigma : float, optional
        Fixed scale [px] of "steger" and "classic"; default σ2. Not allowed with "adaptive".
    curvature_correction : bool, optional
        Move each point by σ²κ/2 away from its centre of curvature (κ fitted along its
        polyline), removing the bias Gaussian smoothing gives curved stripes (0.28 px at
        σ = 7.5 px, R = 100 px). Default: on for "adaptive", off for "steger" and "classic",
        which stay the paper's baselines. With `normal_fit` the matched centres have no
        curvature bias, and this switch is not used.
    asymmetry_correction : bool
        Move each point by the bias an asymmetric cross-section gives it, estimated from
        how far the maximum moves at the nearest other scale of the analysis
        (`pipeline.extraction.asymmetry`), before the curvature correction ("adaptive" and
        "steger").
    scatter_support : bool
        In the curvature fit (run for this even when `curvature_correction` is off), choose
        each point's window along the stripe from the measured centre scatter σl and put
        the point on its fitted curve: texture-robust centres
        (`pipeline.extraction.curvature.remove_curvature_bias`). Not used with `normal_fit`,
        whose along-stripe support is always scatter-chosen.
    normal_fit : bool, optional
        Refine each centre on the frame's profile along its normal with a kernel matched to
        the measured width (`pipeline.extraction.normal_fit`: near the Cramér–Rao bound
        across the stripe, no curvature bias), then put it on its local quadratic fit along
        the polyline over a support chosen from the centre scatter
        (`pipeline.extraction.curvature.smooth_along`). Replaces the curvature correction.
        Default: on for "adaptive", off for "steger" and "classic", the paper's baselines.
    gap_search : bool
        Look for the stripe across gaps between the kept chains whose ends face each other,
        at a smaller contrast than the mask asks for, in a corridor around the path predicted
        from both ends (`pipeline.extraction.gaps.bridge_gaps`; "adaptive" only). Off by
        default: on simulated field passes it measures more wheels but its points lie
        farther from the outline than the chains' (docs/extraction.md §6a).
    glint_subtraction : bool
        Fit the glints the chain rules found as round spots beside the stripe, subtract them
        from the frame and extract the centres again on it (`pipeline.extraction.glints`;
        "adaptive" only: a frame with such spots costs a second extraction). Off by default: on
        by default it cut the camera-rate benchmark below the camera's 60 frames/s
        (docs/extraction.md, "Glints fitted and subtracted").
    full_frame : bool
        Analyse the whole frame (every block) instead of the stripe band located on the
        coarsest scale (the camera-rate path, "adaptive" and "steger"); the same kernels,
        so a frame whose stripe lies inside its band gets the same result either way. The
        band path falls back to the whole frame by itself when it cannot trust the band
        (see `Centres.path`).
    region : PixelRegion, optional
        Search only this part of the frame (e.g. where the calibration says a wheel's stripe
        can lie, `pipeline.calibration.search_region`); coordinates stay the frame's. Inside
        it every strong stripe candidate is kept, however short beside the longest
        (`segmentation.stripe_components`, `every_strong`), and so is a short, dim chain
        of centres that continues a kept one (`_continuing`: a polished flank next to
        its glare); no chain is judged a highlight on a lit body (`_off_bodies`: the
        bloom around a glare raises the shoulders of the stripe's pieces beside it).

    Returns
    -------
    Centres
        Points ordered along linked polylines, with the mask and (adaptive) the σ map.

    Raises
    ------
    ValueError
        On a bad frame (see `pipeline.imaging.validate_image`), an unknown method, a width
        range out of order or non-positive, or a bad sigma.
    TypeError
        If `image` is not an ndarray of a real number type.

    Notes
    -----
    A pixel (r, c) inside the mask holds a centre when λ1 < 0 and the Taylor step
    t = −(nx·Ix + ny·Iy)/(nx²·Ixx + 2nx·ny·Ixy + ny²·Iyy) satisfies |t·nx| ≤ 0.5 and
    |t·ny| ≤ 0.5; the point is (c + t·nx, r + t·ny) [1] (paper eqs. (8)–(10)). "adaptive"
    then keeps the candidates that are lines, not edges (`line_test.is_line`). Points are
    linked into polylines and their widths measured between the gradient maxima; "adaptive"
    drops chains that are round spots or highlights on a lit body (`line_test.is_spot`,
    `line_test.on_bodies`), chains far dimmer than the brightest that are short or lie
    apart from the kept ones, chains wider than CHAIN_WIDTH_FACTOR·width_max and, outside
    a search region, lines (chains joined end to near, not beside: LINE_SIDE_PX) under
    LINE_KEEP_FRACTION of the longest's centres (`segmentation`). Which stage rejects
    what: the mask (`segmentation`) spots, dim outlines, texture, ghosts and short pieces of
    other parts' stripes; the line test step edges and highlights thinner than the stripe;
    the chain rules spots, highlights on a lit body, dim streaks apart from the stripe,
    lines wider than it and specular lines (or a torch's rims beside the stripe) far
    shorter than it; measurement another part's long bright stripe, by its place in the
    track frame.
    The σ map and the mask are those of the pixels, before the sub-pixel step.

    References
    ----------
    [1] C. Steger, 'An unbiased detector of curvilinear structures', IEEE TPAMI 20(2):113-125,
        1998. doi:10.1109/34.659930
    [2] S. Li et al., 'Multi-Scale Adaptive Light Stripe Center Extraction for Line-Structured
        Light Vision Based Online Wheelset Measurement', Sensors, 2026.

    Examples
    --------
    >>> import numpy as np
    >>> rows = np.arange(40.0)[:, None] * np.ones((1, 80))
    >>> image = (20 + 150 * np.exp(-2 * ((rows - 20.3) / 4) ** 2)).astype(np.uint8)
    >>> centres = extract_centres(image, width_min=5, width_max=9)
    >>> bool(np.all(np.abs(centres.y - 20.3) < 0.05))
    True
    """
    validate_image(image)
    if method not in METHODS:
        raise ValueError(f"method must be one of {', '.join(METHODS)}, got {method!r}")
    _check_widths(width_min, width_max)
    _check_sigma(sigma, method)
    frame = image
    if region is not None:
        region.validate(image.shape)
        crop = image[region.row_start : region.row_stop, region.col_start : region.col_stop]
        frame = np.ascontiguousarray(crop)
    extract = functools.partial(
        _extract,
        method=method,
        width_min=width_min,
        width_max=width_max,
        sigma=sigma,
        curvature_correction=curvature_correction,
        asymmetry_correction=asymmetry_correction,
        scatter_support=scatter_support,
        normal_fit=normal_fit,
        gap_search=gap_search,
        full_frame=full_frame,
        every_strong=region is not None,
    )
    found, spot_tops = extract(frame)
    if glint_subtraction and method == "adaptive" and spot_tops.size:
        corrected = _without_glints(frame, found, spot_tops)
        if corrected is not None:
            found, _ = extract(corrected)
    return found if region is None else _in_frame(found, region, image.shape)


def _without_glints(image: np.ndarray, found: Centres, spot_tops: np.ndarray) -> np.ndarray | None:
    """The frame with the glints at `spot_tops` near the centres `found` subtracted
    (`glints.without_glints`), rounded back to the frame's integer type (the second pass
    runs the kernels the first one did, and c keeps its scale); None when no glint is near
    the stripe."""
    stripe_xy = np.column_stack([found.x, found.y])
    corrected = without_glints(image, spot_tops, full_scale(image.dtype), stripe_xy)
    if corrected is None or not np.issubdtype(image.dtype, np.integer):
        return corrected
    top = np.iinfo(image.dtype).max
    return np.clip(np.rint(corrected), 0, top).astype(image.dtype)


def _extract(
    image: np.ndarray,
    method: str,
    width_min: float,
    width_max: float,
    sigma: float | None,
    *,
    curvature_correction: bool | None,
    asymmetry_correction: bool,
    scatter_support: bool,
    normal_fit: bool | None,
    gap_search: bool,
    full_frame: bool,
    every_strong: bool,
) -> tuple[Centres, np.ndarray]:
    """`extract_centres` of a validated frame, one pass, and the tops of the chains dropped
    as round spots (`_spot_tops`, for `_without_glints`); `every_strong` keeps every strong
    stripe candidate (`segmentation.stripe_components`), as inside a search region."""
    sigmas = stripe_scales(float(width_min), float(width_max))
    fixed_sigma = float(sigma) if sigma is not None else sigmas[1]
    c_grey = RIDGE_C_FULL_SCALE * full_scale(image.dtype)
    correct = method == "adaptive" if curvature_correction is None else curvature_correction
    matched = method == "adaptive" if normal_fit is None else normal_fit
    sigma_map = None
    second_levels: tuple[ScaleLevel, ...] = ()
    if method == "classic":
        mask = segment_classic(image)
        scale = analyse_fixed_scale(image, fixed_sigma, c_grey=c_grey)
        selected = _select_fixed(scale, mask, all_blocks(mask.shape))
        path = "full"
    else:
        analysis = analyse_band(
            image,
            sigmas,
            c_grey=c_grey,
            peak_reach_px=width_max / 2,
            full_frame=full_frame,
            every_strong=every_strong,
        )
        mask, blocks, path = analysis.mask, analysis.blocks, analysis.path
        if asymmetry_correction:
            second_levels = tuple(scale.level for scale in analysis.scales)
        if method == "steger":
            reuse = [sc for sc in analysis.scales if sc.level.sigma_px == fixed_sigma]
            if reuse:
                selected = _select_fixed(reuse[0], mask, blocks)
            else:
                scale = analyse_fixed_scale(image, fixed_sigma, c_grey=c_grey)
                selected = _select_fixed(scale, mask, all_blocks(mask.shape))
        else:
            selected, sigma_map = _select_adaptive(analysis.scales, sigmas, mask, blocks)
    return _assemble(
        image,
        selected,
        mask,
        sigma_map=sigma_map,
        method=method,
        sigmas_px=sigmas if method == "adaptive" else (fixed_sigma,),
        width_min=width_min if method == "adaptive" else None,
        width_max=width_max,
        curvature_correction=bool(correct),
        scatter_support=scatter_support,
        normal_fit=bool(matched),
        second_levels=second_levels,
        path=path,
        c_grey=c_grey,
        continuing=every_strong,
        gap_search=gap_search,
    )


def _in_frame(found: Centres, region: PixelRegion, shape: tuple[int, int]) -> Centres:
    """Centres of a crop placed back in the frame: coordinates offset, mask and σ map padded."""
    rows = slice(region.row_start, region.row_stop)
    cols = slice(region.col_start, region.col_stop)
    mask = np.zeros(shape, bool)
    mask[rows, cols] = found.mask
    sigma_map = None
    if found.sigma_map is not None:
        sigma_map = np.zeros(shape, found.sigma_map.dtype)
        sigma_map[rows, cols] = found.sigma_map
    return replace(
        found,
        x=found.x + region.col_start,
        y=found.y + region.row_start,
        rejected_x=found.rejected_x + region.col_start,
        rejected_y=found.rejected_y + region.row_start,
        mask=mask,
        sigma_map=sigma_map,
        region=region,
    )
