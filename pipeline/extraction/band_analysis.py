"""The multi-scale analysis of a frame: per scale V, C, its ridge-peak value and the centre
hints on the blocks of a band, and the stripe mask.

The one implementation of the adaptive method's analysis. The coarsest scale is analysed
over its whole (16× decimated) grid and locates the band; the finer scales are filtered on
the band's blocks only. The whole frame is the band of all blocks: the same kernels, so
inside the band every figure equals the whole frame's, bit for bit. A stripe component
reaching the band's edge sends the frame to the whole frame ("fallback").
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import cv2
import numpy as np

from pipeline.extraction.adaptive import HINT_REACH, LevelResponse
from pipeline.extraction.band import (
    BAND_MARGIN_PX,
    MAX_BAND_FRACTION,
    WIDER_MARGIN_PX,
    StripeBand,
    locate_band,
)
from pipeline.extraction.band_filters import band_derivatives
from pipeline.extraction.band_segmentation import BandMask, segment_band
from pipeline.extraction.blocks import (
    BLOCK_PX,
    all_blocks,
    block_grid,
    block_runs,
    pool_blocks,
    run_starts,
    zero_blocks,
)
from pipeline.extraction.hessian import TINY_NORMAL, eigen2_parts, unit_normal
from pipeline.extraction.ridges import (
    fast_ridge,
    min_structure_squared,
    near_threshold,
    ridge_value,
)
from pipeline.extraction.scalespace import (
    MAX_LEVEL,
    ScaleLevel,
    build_pyramid,
    decimated_variance,
    level_for,
    level_shapes,
)
from pipeline.extraction.segmentation import CONTINUITY_GAP_PX, KEEP_FRACTION
from pipeline.jit import kernel


@kernel
def _analyse_blocks(
    ix, iy, ixx, ixy, iyy, blocks, stride, sigma_px, min_s2, c_grey, hints, into, into_c
):
    """V and C on the band's pixels of one level, in new arrays or in `into` and `into_c`
    (None: new ones; their other pixels are kept); sets the frame pixels hinted at (3×3).

    On the frame grid (stride 1) V is only ever compared with RIDGE_THRESHOLD
    (`band_segmentation._stripe_runs`), so there it is `ridge_estimate` (its side of the
    threshold exact); a coarser grid's V is read bilinearly and is `ridge_value`.

    Per stretch of a row: the candidates are found (one branch-free loop), their
    derivatives gathered, and their eigenvalues (and on the frame grid `fast_ridge`'s V),
    normals, Taylor steps and hinted pixels computed in loops of selects, which vectorise;
    then, candidate by candidate, the V near the threshold or off the frame grid, and the
    hints' writes. A lit frame's grid of σ1 has 851k candidates, most of them texture.
    """
    height, width = ix.shape
    frame_grid = stride == 1
    frame_rows, frame_cols = hints.shape
    # numba compiles `into=None` apart, with arrays of its own: the compiler then knows
    # they alias nothing, and a lit frame's σ1 grid runs 3 % faster than into given arrays.
    if into is None:
        response = np.empty((height, width), np.float32)
        strength = np.empty((height, width), np.float32)
    else:
        response, strength = into, into_c
    norm = sigma_px * sigma_px / (stride * stride)  # σ² and level → frame units of ∂²
    sigma2 = sigma_px * sigma_px
    to_frame = 1.0 / stride
    second = to_frame * to_frame
    origin = 0.5 * (stride - 1)
    least = 0.25 * min_s2
    reach = HINT_REACH * stride
    d_x, d_y = ix.ravel(), iy.ravel()
    d_xx, d_xy, d_yy = ixx.ravel(), ixy.ravel(), iyy.ravel()
    candidate = np.empty(width, np.bool_)
    # The stretch's candidates: column, ∇ and ∂² in frame units, λ1, λ2, unnormalised
    # normal and its length, V (`fast_ridge`), the hinted 3×3's first frame pixel (flat).
    column = np.empty(width, np.int64)
    gx, gy = np.empty(width), np.empty(width)
    hxx, hxy, hyy = np.empty(width), np.empty(width), np.empty(width)
    l1, l2, vx, vy = np.empty(width), np.empty(width), np.empty(width), np.empty(width)
    length, fast = np.empty(width), np.empty(width)
    spot = np.empty(width, np.int64)
    flat_hints = hints.ravel()
    row_step, one, two = np.uint64(frame_cols), np.uint64(1), np.uint64(2)
    last_row, last_col = frame_rows - 1.0, frame_cols - 1.0
    for br, bc0, bc1 in block_runs(blocks):
        c0, c1 = bc0 * BLOCK_PX, min(bc1 * BLOCK_PX, width)
        for r in range(br * BLOCK_PX, min(br * BLOCK_PX + BLOCK_PX, height)):
            response[r, c0:c1] = 0.0
            strength[r, c0:c1] = 0.0
            # As analyse_level: only λ1 < 0 candidates strong enough can matter. The test
            # runs first over the stretch, branch-free and by flat offsets (it vectorises).
            at = np.uint64(r * width + c0)
            for i in range(np.uint64(c1 - c0)):
                dxx, dxy, dyy = d_xx[at + i], d_xy[at + i], d_yy[at + i]
                s2 = (dxx * dxx + dyy * dyy + 2 * dxy * dxy) * (norm * norm)
                candidate[i] = (dxx + dyy < 0) & (s2 > least)
            # Their columns gathered without a branch (a lit frame's texture makes every
            # other pixel a candidate, and a branch on each is mispredicted), then read.
            count = np.uint64(0)
            for i in range(np.uint64(c1 - c0)):
                column[count] = c0 + i
                count += np.uint64(candidate[i])
            for j in range(count):
                p = at + np.uint64(column[j] - c0)
                gx[j] = d_x[p]
                gy[j] = d_y[p]
                hxx[j] = d_xx[p] * second
                hxy[j] = d_xy[p] * second
                hyy[j] = d_yy[p] * second
            for j in range(count):
                l1[j], l2[j], vx[j], vy[j], length[j] = eigen2_parts(hxx[j], hxy[j], hyy[j])
            if frame_grid:
                for j in range(count):
                    fast[j] = fast_ridge(l1[j] * sigma2, l2[j] * sigma2, c_grey)
            # Each hint's 3×3 by `unit_normal`'s division (a tiny eigenvector aside) and the
            # Taylor step: its first pixel, −1 for no hint, −2 where the candidate is
            # decided one by one below (a tiny eigenvector, the 3×3 at the frame's edge).
            for j in range(count):
                lambda1 = l1[j]
                nx, ny = vx[j] / length[j], vy[j] / length[j]
                offset = -(nx * gx[j] + ny * gy[j]) * to_frame / lambda1
                x = column[j] * stride + origin + offset * nx
                y = r * stride + origin + offset * ny
                hr = min(max(np.rint(y), 0.0), last_row)
                hc = min(max(np.rint(x), 0.0), last_col)
                inner = (hr > 0) & (hr < last_row) & (hc > 0) & (hc < last_col)
                first = (int(hr) - 1) * frame_cols + int(hc) - 1 if inner else -2
                first = first if (lambda1 != 0) & (abs(offset) <= reach) else -1
                spot[j] = first if length[j] >= TINY_NORMAL else -2
            for j in range(count):
                c = column[j]
                if frame_grid and not near_threshold(fast[j]):
                    response[r, c] = fast[j]  # `ridge_estimate`, split
                else:
                    response[r, c] = ridge_value(l1[j] * sigma2, l2[j] * sigma2, c_grey)
                strength[r, c] = -sigma2 * min(l1[j], 0.0)
            for j in range(count):
                if spot[j] >= 0:
                    # The 3×3 pixels by flat offsets: no bounds per pixel, no view per hint.
                    flat = np.uint64(spot[j])
                    for _ in range(3):
                        flat_hints[flat] = flat_hints[flat + one] = flat_hints[flat + two] = True
                        flat += row_step
                    continue
                lambda1 = l1[j]
                if spot[j] == -1 or lambda1 == 0:
                    continue
                nx, ny = unit_normal(vx[j], vy[j], length[j])
                offset = -(nx * gx[j] + ny * gy[j]) * to_frame / lambda1
                if abs(offset) > reach:
                    continue
                x = column[j] * stride + origin + offset * nx
                y = r * stride + origin + offset * ny
                hr = min(max(int(np.rint(y)), 0), frame_rows - 1)
                hc = min(max(int(np.rint(x)), 0), frame_cols - 1)
                for rr in range(max(hr - 1, 0), min(hr + 2, frame_rows)):
                    for cc in range(max(hc - 1, 0), min(hc + 2, frame_cols)):
                        hints[rr, cc] = True
    return response, strength


@kernel
def _power_below(span: int) -> int:
    """The largest power of 2 ≤ span."""
    p = 1
    while 2 * p <= span:
        p *= 2
    return p


@kernel
def _running_max(a, b, length, stride, span):
    """Max over windows of `span` entries of rows `stride` apart in a[:length·stride], by
    doubling: after the step of width w, entry j holds the max of rows j .. j + w − 1.
    Uses b as scratch; returns the array holding the windows of width `_power_below(span)`
    (valid for rows ≤ length − that width). C ≥ 0 and max is exact, so the order is free."""
    width = 1
    target = _power_below(span)
    while width < target:
        count = np.uint64((length - width) * stride)
        shift = np.uint64(width * stride)
        for j in range(count):
            b[j] = max(a[j], a[j + shift])
        a, b = b, a
        width *= 2
    return a


@kernel
def _max_along_rows(field, need, valid, half, out) -> None:
    """out[r, c] = max of field[r, c − half .. c + half] (clipped) on the needed blocks,
    the field read as 0 outside its `valid` blocks."""
    height, width = field.shape
    source, target = field.ravel(), out.ravel()
    span = 2 * half + 1
    last = np.uint64(span - _power_below(span))
    a = np.empty(BLOCK_PX * (width + 2 * half), np.float32)
    b = np.empty(BLOCK_PX * (width + 2 * half), np.float32)
    held = block_runs(valid)
    starts = run_starts(held, valid.shape[0])
    for br, first, stop in block_runs(need):
        c0, c1 = first * BLOCK_PX, min(stop * BLOCK_PX, width)
        r0, r1 = br * BLOCK_PX, min(br * BLOCK_PX + BLOCK_PX, height)
        length = c1 - c0 + 2 * half
        # Row r of the block row at a[(r − r0)·length + j] = field[r, c0 − half + j], 0 beyond
        # the grid (C ≥ 0: the same as clipping) and off the valid blocks (the band's ring
        # need not be cleared). The doubling runs over all its rows at once: a window
        # running past its row's end is never read.
        a[: BLOCK_PX * length] = 0.0
        for k in range(starts[br], starts[br + 1]):
            lo = max(c0 - half, held[k, 1] * BLOCK_PX)
            hi = min(c1 + half, held[k, 2] * BLOCK_PX, width)
            if lo >= hi:
                continue
            for r in range(r0, r1):
                read = np.uint64(r * width + lo)
                write = np.uint64((r - r0) * length + lo - (c0 - half))
                for j in range(np.uint64(hi - lo)):
                    a[write + j] = source[read + j]
        windows = _running_max(a, b, BLOCK_PX * length, 1, span)
        for r in range(r0, r1):
            at = np.uint64(r * width + c0)
            row = np.uint64((r - r0) * length)
            for i in range(np.uint64(c1 - c0)):
                target[at + i] = max(windows[row + i], windows[row + i + last])


@kernel
def _max_along_columns(field, blocks, half, out) -> None:
    """out[r, c] = max of field[r − half .. r + half, c] (clipped) on the band's blocks."""
    height, width = field.shape
    source, target = field.ravel(), out.ravel()
    span = 2 * half + 1
    last = span - _power_below(span)
    rows = BLOCK_PX + 2 * half
    a = np.empty(rows * width, np.float32)
    b = np.empty(rows * width, np.float32)
    for br, first, stop in block_runs(blocks):
        c0, c1 = first * BLOCK_PX, min(stop * BLOCK_PX, width)
        n = c1 - c0
        r0 = br * BLOCK_PX
        r1 = min(r0 + BLOCK_PX, height)
        # a[j·n + i] = field[r0 − half + j, c0 + i], 0 beyond the grid.
        a[: rows * n] = 0.0
        for j in range(max(half - r0, 0), min(r1 + half, height) - (r0 - half)):
            read = np.uint64((r0 - half + j) * width + c0)
            write = np.uint64(j * n)
            for i in range(np.uint64(n)):
                a[write + i] = source[read + i]
        windows = _running_max(a, b, rows, n, span)
        for r in range(r0, r1):
            at = np.uint64(r * width + c0)
            top = np.uint64((r - r0) * n)
            bottom = np.uint64((r - r0 + last) * n)
            for i in range(np.uint64(n)):
                target[at + i] = max(windows[top + i], windows[bottom + i])


def _max_filter_blocks(
    field: np.ndarray, blocks: np.ndarray, half: int, valid: np.ndarray | None = None
) -> np.ndarray:
    """Max over the (2·half+1)² square around each pixel of `blocks` (clipped at the grid;
    C ≥ 0, read as 0 outside its `valid` blocks, all when None), written on `blocks` only.

    Separable, on whole runs of blocks: along rows on the rows within `half` of the blocks,
    then along columns on the blocks. Each loop reads one array and writes another, so it
    vectorises.
    """
    reach = -(-half // BLOCK_PX)
    need = cv2.dilate(blocks.astype(np.uint8), np.ones((2 * reach + 1, 1), np.uint8)) > 0
    along_rows = np.empty(field.shape, np.float32)
    if valid is None:
        valid = all_blocks(field.shape)
    _max_along_rows(field, need, valid, half, along_rows)
    out = np.empty(field.shape, np.float32)
    _max_along_columns(along_rows, blocks, half, out)
    return out


def analyse_band_level(
    level: ScaleLevel,
    blocks: np.ndarray,
    ring: np.ndarray,
    *,
    c_grey: float,
    frame_shape: tuple[int, int],
    hint_blocks: np.ndarray,
    into: LevelResponse | None = None,
) -> LevelResponse:
    """`pipeline.extraction.adaptive.analyse_level` on the band's blocks of one level, but for the
    ridge-peak strength, which `with_peak_strength` adds once the mask is known.

    Parameters
    ----------
    level : ScaleLevel
        Derivatives of the scale (valid on the band's blocks).
    blocks : ndarray of bool
        The band's blocks of that level.
    ring : ndarray of bool
        The blocks around them set to 0 (see `pipeline.extraction.band.RING_BLOCKS`).
    c_grey : float
        Structure constant of the ridge response [grey levels].
    frame_shape : tuple of int
        Frame shape (M, N).
    hint_blocks : ndarray of bool
        The frame's (level-0) blocks where the hints are read: they are valid there only
        (the mask lies on these blocks). Clearing a frame-sized array for each scale cost
        more than the hints themselves.
    into : LevelResponse, optional
        The same level analysed on other blocks (a refused band), completed in place on
        `blocks`; its hints must already be valid (0 or hinted) on `hint_blocks`.

    Returns
    -------
    LevelResponse
        V and C (`peak_strength` holds C itself), valid on the band and, on a decimated
        level, its ring; the hints, valid on `hint_blocks`.
    """
    d = level.derivatives
    if into is not None:
        hints = into.hints
    elif hint_blocks.all():
        hints = np.zeros(frame_shape, np.bool_)  # one memset, not a loop over 8-px rows
    else:
        hints = np.empty(frame_shape, np.bool_)
        zero_blocks(hints, hint_blocks)
    response, strength = _analyse_blocks(
        d.ix,
        d.iy,
        d.ixx,
        d.ixy,
        d.iyy,
        blocks,
        level.stride,
        level.sigma_px,
        min_structure_squared(c_grey),
        c_grey,
        hints,
        None if into is None else into.response,
        None if into is None else into.peak_strength,
    )
    # The frame grid's V and C are read on the band only (`band_segmentation`; the max
    # filter reads C on the band's blocks); a coarser grid's by bilinear reads, which reach
    # into the ring.
    if level.stride > 1:
        for field in (response, strength):
            zero_blocks(field, ring)
    return LevelResponse(level=level, response=response, peak_strength=strength, hints=hints)


def with_peak_strength(
    scale: LevelResponse,
    mask_blocks: np.ndarray,
    *,
    peak_reach_px: float,
    valid: np.ndarray | None = None,
) -> LevelResponse:
    """The scale with C max-filtered (its ridge-peak value) on the blocks holding the mask.

    `mask_blocks` are the level's blocks that hold mask pixels, widened by one block for the
    bilinear reads of coarser levels; only there is the peak strength read
    (`adaptive.choose_in_band`), and only there is it written. C is read as 0 outside its
    `valid` blocks (None: all; the frame grid's band, whose ring is not cleared).
    """
    half = max(1, round(peak_reach_px / scale.level.stride))
    peak = _max_filter_blocks(scale.peak_strength, mask_blocks, half, valid)
    return replace(scale, peak_strength=peak)


def _left_out_safely(band: StripeBand, found: BandMask, stride: int) -> bool:
    """Whether no region left out of the band could hold a piece of the stripe found in it.

    A left-out region of extent D holds no component of length ≥ √3·D, and components kept
    by length are ≥ KEEP_FRACTION of the stripe's; and none may lie within
    CONTINUITY_GAP_PX of the mask (pieces there would continue it).

    Not checked: whether a left-out region holds a line stronger than the strongest
    candidate in the band, which on the whole frame would raise the strong pieces' bar
    (`segmentation.STRONG_FRACTION`); bounding it from the seed's scale alone keeps the
    spots of a cluttered frame in the band and doubles its time.
    """
    if band.left_out is None:
        return True
    if math.sqrt(3.0) * band.left_out_px >= KEEP_FRACTION * found.stripe_length_px:
        return False
    # The mask's blocks (it lies on the band's) spread onto the seed grid, then widened.
    held = found.held
    grid = band.left_out.shape
    if stride > BLOCK_PX:
        cells = pool_blocks(held, stride // BLOCK_PX, grid)
    else:
        # Each block as its (BLOCK_PX/stride)² seed cells (np.kron did the same at 1.2 ms).
        ratio = BLOCK_PX // stride
        cells = held.repeat(ratio, axis=0).repeat(ratio, axis=1)[: grid[0], : grid[1]]
    spread = np.zeros(grid, np.uint8)
    spread[: cells.shape[0], : cells.shape[1]] = cells
    reach = math.ceil(CONTINUITY_GAP_PX / stride) + 1
    near = cv2.dilate(spread, np.ones((2 * reach + 1,) * 2, np.uint8)) > 0
    return not (near & band.left_out).any()


@dataclass(frozen=True, slots=True, eq=False)
class BandAnalysis:
    """The multi-scale analysis of a frame inside its stripe band.

    `scales` one LevelResponse per scale σ1..σS (fields valid on the band, 0 on its ring);
    `band` the band (None for the whole frame); `blocks` the frame's (level-0) blocks
    holding the mask (all its readers need); `mask` (M, N) bool the stripe mask; `path`
    "band", "wide band" (the wider band was needed), "full" (the whole frame, asked for) or
    "fallback" (the whole frame because no band could be trusted, `reason` says why).
    """

    sigmas_px: tuple[float, ...]
    scales: tuple[LevelResponse, ...]
    band: StripeBand | None
    blocks: np.ndarray
    mask: np.ndarray
    path: str
    reason: str = ""


@dataclass(frozen=True, slots=True, eq=False)
class _Pyramid:
    """The frame's pyramid and the level of each scale."""

    image: np.ndarray
    levels: tuple[np.ndarray, ...]
    shapes: tuple[tuple[int, int], ...]
    scale_levels: tuple[int, ...]


def _pyramid(image: np.ndarray, sigmas_px: tuple[float, ...], max_level: int) -> _Pyramid:
    scale_levels = tuple(level_for(s, max_level) for s in sigmas_px)
    coarsest = max(scale_levels)
    levels = build_pyramid(image, coarsest)
    levels[0] = image
    return _Pyramid(image, tuple(levels), level_shapes(image.shape, coarsest), scale_levels)


def _residual_sigma(sigma_px: float, level: int) -> float:
    """The Gaussian σ [px of that level] that, filtered on pyramid `level`, gives scale
    `sigma_px` [frame px] with the blur its decimation already holds."""
    return math.sqrt(sigma_px**2 - decimated_variance(level)) / 2**level


def _analysed(
    pyramid: _Pyramid, sigma_px: float, level: int, blocks, ring, c_grey: float, hint_blocks
) -> LevelResponse:
    """One scale's V, C and hints on the blocks of its level (the hints valid on the frame's
    `hint_blocks`)."""
    derivatives = band_derivatives(
        pyramid.levels[level], _residual_sigma(sigma_px, level), blocks, ring
    )
    return analyse_band_level(
        ScaleLevel(float(sigma_px), level, derivatives),
        blocks,
        ring,
        c_grey=c_grey,
        frame_shape=pyramid.image.shape,
        hint_blocks=hint_blocks,
    )


def analyse_fixed_scale(
    image: np.ndarray, sigma_px: float, *, c_grey: float, max_level: int = MAX_LEVEL
) -> LevelResponse:
    """One scale's V, C (not max-filtered) and centre hints over the whole frame.

    Parameters
    ----------
    image : ndarray of shape (M, N), uint8, uint16 or float
        Grey frame [grey levels], validated.
    sigma_px : float
        Scale [px], on the coarsest pyramid level ≤ `max_level` it fits (`level_for`).
    c_grey : float
        Structure constant of the ridge response [grey levels].
    """
    pyramid = _pyramid(image, (sigma_px,), max_level)
    level = pyramid.scale_levels[0]
    blocks = all_blocks(pyramid.shapes[level])
    return _analysed(pyramid, sigma_px, level, blocks, ~blocks, c_grey, all_blocks(image.shape))


def _with_peaks(
    scales, levels, shapes, held: np.ndarray, blocks: np.ndarray, peak_reach_px: float
) -> tuple[LevelResponse, ...]:
    """Each scale with C max-filtered on the blocks holding the mask (see `with_peak_strength`);
    `held` those of the frame (level 0), `blocks` the band's."""
    peaked = []
    for scale, level in zip(scales, levels, strict=True):
        mask_blocks = held
        if level:
            mask_blocks = pool_blocks(held, 2**level, block_grid(shapes[level]))
            mask_blocks = cv2.dilate(mask_blocks.astype(np.uint8), np.ones((3, 3), np.uint8)) > 0
        peaked.append(
            with_peak_strength(
                scale, mask_blocks, peak_reach_px=peak_reach_px, valid=None if level else blocks
            )
        )
    return tuple(peaked)


def _segment(scales, levels, blocks, shape, c_grey, every_strong):
    """`segment_band` of the scales' V and C (C not yet max-filtered); `blocks` per level,
    the frame's first."""
    return segment_band(
        tuple(sc.response for sc in scales),
        tuple(sc.peak_strength for sc in scales),
        tuple(2**lv for lv in levels),
        blocks[0],
        shape,
        c_grey,
        every_strong=every_strong,
    )


@kernel
def _spread_blocks(blocks, stride, reach, rows, cols):
    """The (rows, cols) frame blocks within `reach` blocks of a level's `blocks`, each
    `stride` × `stride` frame blocks (a few µs: cv2.dilate of their expansion took 40)."""
    out = np.zeros((rows, cols), np.bool_)
    for br in range(blocks.shape[0]):
        for bc in range(blocks.shape[1]):
            if blocks[br, bc]:
                r0, c0 = max(br * stride - reach, 0), max(bc * stride - reach, 0)
                out[r0 : (br + 1) * stride + reach, c0 : (bc + 1) * stride + reach] = True
    return out


def _hinted(blocks: np.ndarray, stride: int, grid: tuple[int, int]) -> np.ndarray:
    """The frame's (level-0) blocks, of `grid`, that a level's `blocks` (of `stride` frame
    px per level px) can hint at: a hint's 3×3 lies within HINT_REACH·stride + 1.5 frame px
    of its candidate."""
    reach = math.ceil((HINT_REACH * stride + 2) / BLOCK_PX)
    return _spread_blocks(blocks, stride, reach, grid[0], grid[1])


def _in_band(pyramid, sigmas_px, seed_index, seed, c_grey, every_strong):
    """The stripe mask inside the band located on the coarsest scale: (band, scales, mask,
    widened), or why no band can be trusted: (reason, band, scales), the last band analysed
    and its scales (for the whole frame to complete), None and [] if none was."""
    coarsest = pyramid.scale_levels[seed_index]
    analysed = [None, []]  # the last band analysed and its scales

    def attempt(margin: float, leave_out_small: bool):
        band = locate_band(
            seed.response,
            coarsest,
            pyramid.shapes,
            margin_px=margin,
            leave_out_small=leave_out_small,
        )
        if band.fraction > MAX_BAND_FRACTION:
            return band, [], None
        before, before_scales = analysed
        scales = []
        for i, (sigma, lv) in enumerate(zip(sigmas_px, pyramid.scale_levels, strict=True)):
            if i == seed_index:
                scales.append(seed)
            elif before is not None and not (before.blocks[lv] & ~band.blocks[lv]).any():
                # The band tried last lies inside this one (a wider one): its fields grow.
                scales.append(_completed(pyramid, before_scales[i], before, c_grey, band))
            else:
                # Hints valid wherever the band's candidates can hint (not just on its
                # frame blocks), so that they are complete there (`_completed`).
                hinted = _hinted(band.blocks[lv], 2**lv, band.blocks[0].shape)
                scales.append(
                    _analysed(pyramid, sigma, lv, band.blocks[lv], band.rings[lv], c_grey, hinted)
                )
        analysed[:] = band, scales
        return (
            band,
            scales,
            _segment(
                scales,
                pyramid.scale_levels,
                band.blocks,
                pyramid.image.shape,
                c_grey,
                every_strong,
            ),
        )

    # A stripe the band cuts (a spot fused to its edge, a faint end) gets one wider band.
    for margin in (BAND_MARGIN_PX, WIDER_MARGIN_PX):
        band, scales, found = attempt(margin, True)
        # The regions left out must be too small for a piece of the stripe actually found.
        if found is not None and not _left_out_safely(band, found, 2**coarsest):
            band, scales, found = attempt(margin, False)
        if found is None:
            return (f"the band covers {100 * band.fraction:.0f} % of the frame", *analysed)
        if found.inside:
            return band, scales, found, margin != BAND_MARGIN_PX
    return ("a stripe component reaches the band's edge", *analysed)


def _completed(
    pyramid: _Pyramid,
    scale: LevelResponse,
    band: StripeBand,
    c_grey: float,
    into_band: StripeBand | None = None,
) -> LevelResponse:
    """One scale's V, C and hints on a band holding `band` (`into_band`; None: the whole
    frame), from its analysis on `band`: the blocks it lacks are filtered and analysed
    into its arrays, in place (`band`'s fields are then lost).

    Every block's derivatives, V and C depend on the image only, and the hints are an OR
    of 3×3 marks, so the fields equal those analysed from scratch, bit for bit. The hints
    are valid on the frame blocks `band`'s candidates can hint at (`_hinted`; the rest of
    the array is garbage), so they are cleared on the others the new band reads.
    """
    level = scale.level
    lv, stride = level.level, level.stride
    have = band.blocks[lv]
    grid = band.blocks[0].shape
    if into_band is None:
        target, ring, hint_blocks = (
            np.ones_like(have),
            np.zeros_like(have),
            all_blocks(pyramid.image.shape),
        )
    else:
        target, ring = into_band.blocks[lv], into_band.rings[lv]
        hint_blocks = _hinted(target, stride, grid)
    missing = target & ~have
    band_derivatives(
        pyramid.levels[lv],
        _residual_sigma(level.sigma_px, lv),
        missing,
        ring,
        into=level.derivatives,
    )
    zero_blocks(scale.hints, hint_blocks & ~_hinted(have, stride, grid))
    return analyse_band_level(
        level,
        missing,
        ring,
        c_grey=c_grey,
        frame_shape=pyramid.image.shape,
        hint_blocks=hint_blocks,
        into=scale,
    )


def analyse_band(
    image: np.ndarray,
    sigmas_px: tuple[float, ...],
    *,
    c_grey: float,
    peak_reach_px: float,
    full_frame: bool = False,
    every_strong: bool = False,
    max_level: int = MAX_LEVEL,
) -> BandAnalysis:
    """Multi-scale analysis and stripe mask of a frame, inside its stripe band.

    Parameters
    ----------
    image : ndarray of shape (M, N), uint8, uint16 or float
        Grey frame [grey levels], validated.
    sigmas_px : tuple of float
        Scales [px], ascending; the last sits on the coarsest pyramid level and locates
        the band.
    c_grey : float
        Structure constant of the ridge response [grey levels].
    peak_reach_px : float
        Half-size of the max filter of C [px].
    full_frame : bool
        Analyse the band of all blocks (the whole frame) without locating a band.
    every_strong : bool
        Keep every strong stripe candidate (`segmentation.stripe_components`): the frame is
        a search region the calibration bounds.
    max_level : int
        Coarsest pyramid level.

    Returns
    -------
    BandAnalysis
        On the whole frame ("fallback") when the coarsest scale is on the frame grid, the
        band covers most of the frame, or a stripe component reaches the band's edge.

    Notes
    -----
    The whole frame is the band of every block: the same kernels, so a frame whose stripe
    lies inside its band gets the same fields, mask and centres on either path.
    """
    pyramid = _pyramid(image, sigmas_px, max_level)
    levels, shapes = pyramid.scale_levels, pyramid.shapes
    everywhere = tuple(all_blocks(shape) for shape in shapes)
    seed_index = max(range(len(levels)), key=lambda i: (levels[i], sigmas_px[i]))
    seed = None
    refused: StripeBand | None = None  # the last band analysed, if it was refused
    band_scales: list[LevelResponse] = []
    reason = "asked for"
    if not full_frame and levels[seed_index] == 0:
        reason = "no scale on a decimated grid"
    elif not full_frame:
        grid = everywhere[levels[seed_index]]
        seed = _analysed(
            pyramid, sigmas_px[seed_index], levels[seed_index], grid, ~grid, c_grey, everywhere[0]
        )
        found = _in_band(pyramid, sigmas_px, seed_index, seed, c_grey, every_strong)
        if not isinstance(found[0], str):
            band, scales, inside, widened = found
            return BandAnalysis(
                tuple(float(s) for s in sigmas_px),
                _with_peaks(scales, levels, shapes, inside.held, band.blocks[0], peak_reach_px),
                band,
                inside.held,
                inside.mask,
                "wide band" if widened else "band",
            )
        reason, refused, band_scales = found
    scales = [
        seed
        if seed is not None and i == seed_index
        # The refused band's fields are completed on the blocks it lacks.
        else _completed(pyramid, band_scales[i], refused, c_grey)
        if refused is not None
        else _analysed(pyramid, sigma, lv, everywhere[lv], ~everywhere[lv], c_grey, everywhere[0])
        for i, (sigma, lv) in enumerate(zip(sigmas_px, levels, strict=True))
    ]
    whole = _segment(scales, levels, everywhere, image.shape, c_grey, every_strong)
    return BandAnalysis(
        tuple(float(s) for s in sigmas_px),
        _with_peaks(scales, levels, shapes, whole.held, everywhere[0], peak_reach_px),
        None,
        whole.held,
        whole.mask,
        "full" if full_frame else "fallback",
        reason,
    )
