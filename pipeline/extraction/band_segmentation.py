"""Stripe mask inside a band: V = max over scales, threshold, 8-connected components, the
stripe's components, closing. The band of all blocks is the whole frame."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pipeline.extraction.blocks import BLOCK_PX, block_runs, blocks_holding, run_starts
from pipeline.extraction.closing import close_runs
from pipeline.extraction.components import (
    append_runs,
    label_maxima,
    label_runs,
    labels_within,
    room_for_runs,
    shapes_from_moments,
)
from pipeline.extraction.ridges import RIDGE_THRESHOLD
from pipeline.extraction.scalespace import blend, column_taps, linear_tap
from pipeline.extraction.segmentation import (
    CONTINUITY_GAP_PX,
    candidates,
    continuity_labels,
    stripe_components,
)
from pipeline.jit import kernel


@dataclass(frozen=True, slots=True, eq=False)
class BandMask:
    """The stripe mask found inside a band.

    `mask` (M, N) bool is the closed stripe mask, all False when not `inside`; `held` (bool,
    the band's grid) the band's blocks holding mask pixels; `inside` is False when a
    component that is or looks like part of the stripe comes within EDGE_REACH_PX of the
    band's edge, where the band may have cut it (the whole frame must then decide);
    `stripe_length_px` is the length L of the longest stripe component (0 when there is none).
    """

    mask: np.ndarray
    held: np.ndarray
    inside: bool
    stripe_length_px: float


ALONG_ROWS = BLOCK_PX + 2
"""Level rows `_stripe_runs` keeps interpolated along x: more than the BLOCK_PX/2 + 2 a
block row reads at stride 2, so the rows it shares with the next block row are kept."""


@kernel
def _same_runs(band, starts, before, row) -> bool:
    """Whether block row `row` follows block row `before` and has the same band runs."""
    if before != row - 1 or starts[row + 1] - starts[row] != starts[before + 1] - starts[before]:
        return False
    for k in range(starts[row + 1] - starts[row]):
        now, then = band[starts[row] + k], band[starts[before] + k]
        if now[1] != then[1] or now[2] != then[2]:
            return False
    return True


@kernel
def _stripe_runs(responses, strides, blocks, shape):
    """Runs of V = max over scales > RIDGE_THRESHOLD along the band's frame rows, raster
    order: rows of (row, first, stop).

    Coarser scales' V is upsampled bilinearly as cv2.resize INTER_LINEAR does it: along x
    first, then along y. Each level row a block row of the band reads is interpolated along
    x once (kept for the next block row where it reads the same row and columns), so each
    frame pixel costs one y interpolation per scale (the same sums as pixel by pixel).
    """
    height, width = shape
    levels = len(responses)
    x0, x1, fx = column_taps(responses, strides, width)
    # Level rows along x, per scale: level row y at y % ALONG_ROWS (a block row reads at
    # most BLOCK_PX/2 + 2 rows); done[i] the last row interpolated for the current columns.
    along_x = np.zeros((levels, ALONG_ROWS, width))
    done = np.full(levels, -1)
    line = np.zeros(width, np.bool_)
    edges = np.empty(width + 1, np.int64)
    band = block_runs(blocks)
    starts = run_starts(band, blocks.shape[0])
    runs = room_for_runs(band, height)
    count = 0
    last = -2  # the block row read last
    for br in range(blocks.shape[0]):
        if starts[br] == starts[br + 1]:
            continue
        r0, r1 = br * BLOCK_PX, min(br * BLOCK_PX + BLOCK_PX, height)
        if not _same_runs(band, starts, last, br):
            done[:] = -1
        last = br
        for i in range(levels):
            field, stride = responses[i], strides[i]
            if stride == 1:
                continue
            top = linear_tap(r0, stride, field.shape[0])[0]
            bottom = linear_tap(r1 - 1, stride, field.shape[0])[1]
            for y in range(max(top, done[i] + 1), bottom + 1):
                source, target = field[y], along_x[i, y % ALONG_ROWS]
                for k in range(starts[br], starts[br + 1]):
                    for c in range(band[k, 1] * BLOCK_PX, min(band[k, 2] * BLOCK_PX, width)):
                        a, b, w = x0[i, c], x1[i, c], fx[i, c]
                        target[c] = source[a] * (1 - w) + source[b] * w
            done[i] = max(done[i], bottom)
        for r in range(r0, r1):
            for k in range(starts[br], starts[br + 1]):
                c0, c1 = band[k, 1] * BLOCK_PX, min(band[k, 2] * BLOCK_PX, width)
                n = np.uint64(c1 - c0)
                start = np.uint64(c0)
                for c in range(n):
                    line[start + c] = False
                # Unsigned flat offsets into whole arrays: no per-view alias checks each time
                # a loop starts, so short band runs vectorise too (see band_filters).
                for i in range(levels):
                    field, stride = responses[i], strides[i]
                    if stride == 1:
                        source = field.ravel()
                        at = np.uint64(r * width + c0)
                        for c in range(n):
                            line[start + c] |= source[at + c] > RIDGE_THRESHOLD
                        continue
                    y0, y1, fy = linear_tap(r, stride, field.shape[0])
                    rows = along_x[i].ravel()
                    upper = np.uint64((y0 % ALONG_ROWS) * width + c0)
                    lower = np.uint64((y1 % ALONG_ROWS) * width + c0)
                    for c in range(n):
                        value = rows[upper + c] * (1 - fy) + rows[lower + c] * fy
                        line[start + c] |= value > RIDGE_THRESHOLD
                count = append_runs(line, r, c0, c1, runs, count, edges)
    return runs[:count].copy()


PEAK_BOUND_MARGIN = 1e-12
"""Relative margin of the bound on a run's bilinear C (`_run_peaks`): a bilinear value of
non-negative taps with weights summing to 1 exceeds the largest tap by at most 4 roundings
(4·2⁻⁵³ ≈ 4.4·10⁻¹⁶ of it)."""


@kernel
def _run_peaks(runs, strengths, strides, width):
    """The largest C = max over scales of σ²|λ1| (bilinear on coarser levels, as V) over
    the pixels of each run: (K,) float64. Each run's rows are read straight into its
    maximum (max is exact, so in any order), no value stored per pixel.

    A coarser level is read only where the largest of the taps its bilinear values would
    blend, less PEAK_BOUND_MARGIN, reaches the run's maximum so far: otherwise no value
    of it can raise the maximum (on a lit frame's runs about 9 in 10 levels are skipped).
    """
    peak = np.zeros(runs.shape[0])
    u0, u1, fu = column_taps(strengths, strides, width)
    levels = len(strengths)
    v0, v1, fv = np.zeros(levels, np.int64), np.zeros(levels, np.int64), np.zeros(levels)
    row = -1
    for k in range(runs.shape[0]):
        r, c0, c1 = runs[k, 0], runs[k, 1], runs[k, 2]
        if r != row:  # runs come in raster order: the row taps once per row
            row = r
            for i in range(levels):
                if strides[i] > 1:
                    v0[i], v1[i], fv[i] = linear_tap(r, strides[i], strengths[i].shape[0])
        best = 0.0
        for i in range(levels):
            field = strengths[i]
            if strides[i] == 1:
                for c in range(c0, c1):
                    best = max(best, field[r, c])
                continue
            upper, lower = v0[i], v1[i]
            bound = 0.0
            for u in range(u0[i, c0], u1[i, c1 - 1] + 1):
                bound = max(bound, max(field[upper, u], field[lower, u]))
            if bound * (1 + PEAK_BOUND_MARGIN) < best:
                continue
            for c in range(c0, c1):
                best = max(best, blend(field, upper, lower, fv[i], u0[i, c], u1[i, c], fu[i, c]))
        peak[k] = best
    return peak


@kernel
def runs_near_band_edge(runs, blocks, reach):
    """Whether a pixel of each run has a pixel outside the band within `reach` (Chebyshev;
    beyond the frame counts as band): whether a block the run's square neighbourhood
    overlaps is not in the band."""
    out = np.zeros(runs.shape[0], np.bool_)
    last_r, last_c = blocks.shape[0] - 1, blocks.shape[1] - 1
    for k in range(runs.shape[0]):
        r, first, stop = runs[k, 0], runs[k, 1], runs[k, 2]
        br0 = max(r - reach, 0) // BLOCK_PX
        br1 = min((r + reach) // BLOCK_PX, last_r)
        bc0 = max(first - reach, 0) // BLOCK_PX
        bc1 = min((stop - 1 + reach) // BLOCK_PX, last_c)
        for br in range(br0, br1 + 1):
            for bc in range(bc0, bc1 + 1):
                if not blocks[br, bc]:
                    out[k] = True
    return out


EDGE_REACH_PX = 5
"""A stripe pixel closer than this to the band's edge may be cut by it [px]: a centre hint
reaches 4 px (one stride of level 2)."""


def _components(runs, run_strength):
    """Labels of the runs, the components' shapes and their largest C."""
    label, moments = label_runs(runs)
    strength = label_maxima(label, run_strength, moments.shape[0])
    return label, shapes_from_moments(*moments.T), strength


def segment_band(
    responses: tuple[np.ndarray, ...],
    strengths: tuple[np.ndarray, ...],
    strides: tuple[int, ...],
    blocks: np.ndarray,
    shape: tuple[int, int],
    c_grey: float,
    *,
    every_strong: bool = False,
) -> BandMask:
    """Stripe mask from the scales' ridge responses inside the band.

    Parameters
    ----------
    responses : tuple of ndarray, float32
        V of each scale on its level's grid (0 outside the band).
    strengths : tuple of ndarray, float32
        C = σ²|λ1| of each scale on its level's grid [grey levels] (0 outside the band).
    strides : tuple of int
        Each level's stride 2^L.
    blocks : ndarray of bool
        The band's frame (level-0) blocks.
    shape : tuple of int
        Frame shape (M, N).
    c_grey : float
        The ridge response's structure constant c [grey levels] (`ridges`).
    every_strong : bool
        Keep every strong candidate (`segmentation.stripe_components`: inside a search
        region).

    Returns
    -------
    BandMask

    Notes
    -----
    V > RIDGE_THRESHOLD, 8-connected components, the stripe's among them
    (`segmentation.stripe_components`), closed. With every block in the band (the whole
    frame) no component comes near the band's edge: the frame's edge counts as band.
    """
    runs = _stripe_runs(responses, strides, blocks, shape)
    label, shapes, strength = _components(runs, _run_peaks(runs, strengths, strides, shape[1]))
    consider = continuity_labels(shapes, strength, c_grey, every_strong)
    near = None
    if consider is not None:
        near = labels_within(runs, label, consider, CONTINUITY_GAP_PX)
    keep = stripe_components(shapes, strength, near, c_grey, every_strong=every_strong)
    # A component the band may have cut: one shaped like a stripe piece, or kept (a compact
    # one continuing a piece). A round spot (a specular reflection beside the stripe) left
    # out is not, whole or cut, so it may.
    piece = candidates(shapes) | keep
    touching = np.zeros(keep.size, bool)
    if not blocks.all():  # the frame's edge counts as band: nothing nears the whole frame's
        touching[label[runs_near_band_edge(runs, blocks, EDGE_REACH_PX)]] = True
    inside = not (touching & piece).any()
    if inside:
        mask = close_runs(runs, keep[label], blocks, shape)
        held = blocks_holding(mask, blocks)
    else:
        mask = np.zeros(shape, np.bool_)
        held = np.zeros(blocks.shape, np.bool_)
    return BandMask(
        mask=mask,
        held=held,
        inside=inside,
        stripe_length_px=float(shapes.length_px[keep].max()) if keep.any() else 0.0,
    )
