"""Stripe mask inside the band: V = max over scales, threshold, 8-connected components,
the stripe's components, closing; as `segment_ridges`, on the band's pixels only."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pipeline.extraction.band import BLOCK_PX, block_runs, run_starts, zero_blocks
from pipeline.extraction.ridges import RIDGE_THRESHOLD
from pipeline.extraction.scalespace import column_taps, linear_tap
from pipeline.extraction.segmentation import (
    CLOSING_PX,
    MIN_COMPONENT_AREA_PX,
    MIN_ELONGATION,
    close_holes,
    shapes_from_moments,
    stripe_components,
)
from pipeline.jit import kernel


@dataclass(frozen=True, slots=True, eq=False)
class BandMask:
    """The stripe mask found inside a band.

    `mask` (M, N) bool is the closed stripe mask; `inside` is False when a component that is
    or looks like part of the stripe comes within EDGE_REACH_PX of the band's edge, where the
    band may have cut it (the full-frame path must then decide); `stripe_length_px` is the
    length L of the longest stripe component (0 when there is none).
    """

    mask: np.ndarray
    inside: bool
    stripe_length_px: float


@kernel
def _append_runs(line, row, first, stop, runs, count) -> int:
    """Write the runs of True in line[first:stop] as (row, first, stop) from runs[count];
    returns the new count. `runs` must have room (`_room_for_runs`)."""
    inside = False
    start = first
    for c in range(first, stop):
        if line[c] != inside:
            if inside:
                runs[count, 0], runs[count, 1], runs[count, 2] = row, start, c
                count += 1
            else:
                start = c
            inside = not inside
    if inside:
        runs[count, 0], runs[count, 1], runs[count, 2] = row, start, stop
        count += 1
    return count


@kernel
def _room_for_runs(band, height):
    """An empty (K, 3) run array with room for every run the band's rows can hold: a row
    stretch of n pixels holds at most (n + 1) // 2."""
    most = 0
    for k in range(band.shape[0]):
        rows = min(BLOCK_PX, height - band[k, 0] * BLOCK_PX)
        most += rows * (((band[k, 2] - band[k, 1]) * BLOCK_PX + 1) // 2)
    return np.empty((most, 3), np.int64)


@kernel
def _stripe_runs(responses, strides, blocks, shape):
    """Runs of V = max over scales > RIDGE_THRESHOLD along the band's frame rows, raster
    order: rows of (row, first, stop).

    Coarser scales' V is upsampled bilinearly as cv2.resize INTER_LINEAR does it: along x
    first, then along y. The x interpolation of the level rows a block row of the band
    reads is done once for that block row, so each frame pixel costs one y interpolation
    per scale (the same sums as pixel by pixel).
    """
    height, width = shape
    levels = len(responses)
    x0, x1, fx = column_taps(responses, strides, width)
    # Level rows along x, per scale: rows first_row[i] .. + BLOCK_PX + 1 of the block row.
    along_x = np.zeros((levels, BLOCK_PX + 2, width))
    first_row = np.zeros(levels, np.int64)
    line = np.zeros(width, np.bool_)
    band = block_runs(blocks)
    starts = run_starts(band, blocks.shape[0])
    runs = _room_for_runs(band, height)
    count = 0
    for br in range(blocks.shape[0]):
        if starts[br] == starts[br + 1]:
            continue
        r0, r1 = br * BLOCK_PX, min(br * BLOCK_PX + BLOCK_PX, height)
        for i in range(levels):
            field, stride = responses[i], strides[i]
            if stride == 1:
                continue
            top = linear_tap(r0, stride, field.shape[0])[0]
            bottom = linear_tap(r1 - 1, stride, field.shape[0])[1]
            first_row[i] = top
            for y in range(top, bottom + 1):
                source, target = field[y], along_x[i, y - top]
                for k in range(starts[br], starts[br + 1]):
                    for c in range(band[k, 1] * BLOCK_PX, min(band[k, 2] * BLOCK_PX, width)):
                        a, b, w = x0[i, c], x1[i, c], fx[i, c]
                        target[c] = source[a] * (1 - w) + source[b] * w
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
                    upper = np.uint64((y0 - first_row[i]) * width + c0)
                    lower = np.uint64((y1 - first_row[i]) * width + c0)
                    for c in range(n):
                        value = rows[upper + c] * (1 - fy) + rows[lower + c] * fy
                        line[start + c] |= value > RIDGE_THRESHOLD
                count = _append_runs(line, r, c0, c1, runs, count)
    return runs[:count].copy()


@kernel
def _find(parent, p):
    while parent[p] != p:
        parent[p] = parent[parent[p]]
        p = parent[p]
    return p


@kernel
def _row_runs(binary, blocks):
    """Runs of True pixels along the band's rows, raster order: rows of (row, first, stop)."""
    height, width = binary.shape
    band = block_runs(blocks)
    starts = run_starts(band, blocks.shape[0])
    runs = _room_for_runs(band, height)
    count = 0
    for r in range(height):
        br = r // BLOCK_PX
        for k in range(starts[br], starts[br + 1]):
            c0, c1 = band[k, 1] * BLOCK_PX, min(band[k, 2] * BLOCK_PX, width)
            count = _append_runs(binary[r], r, c0, c1, runs, count)
    return runs[:count].copy()


@kernel
def _label_runs(runs):
    """8-connected components of row runs (raster order): each run's label and the moments.

    Runs of consecutive rows touch when their column spans overlap or meet at a corner.
    Union-find with the earlier run as root, so labels follow the components' first pixels.
    `moments[k]` holds the area and the sums of r, c, r², c², r·c of component k (row 0, the
    background, stays 0).
    """
    count = runs.shape[0]
    parent = np.arange(count)
    previous = 0  # first run of the previous row
    for k in range(count):
        r, c0, c1 = runs[k, 0], runs[k, 1], runs[k, 2]
        while previous < k and runs[previous, 0] < r - 1:
            previous += 1
        j = previous
        while j < k and runs[j, 0] == r - 1:
            if runs[j, 1] <= c1 and c0 <= runs[j, 2]:
                a, b = _find(parent, k), _find(parent, j)
                if a != b:
                    parent[max(a, b)] = min(a, b)
            j += 1
    label = np.empty(count, np.int64)
    components = 1
    for k in range(count):
        root = _find(parent, k)
        if root == k:
            label[k] = components
            components += 1
        else:
            label[k] = label[root]
    moments = np.zeros((components, 6))
    for k in range(count):
        r, c0, c1 = float(runs[k, 0]), float(runs[k, 1]), float(runs[k, 2])
        n = c1 - c0
        sum_c = n * (c0 + c1 - 1) / 2
        sum_cc = ((c1 - 1) * c1 * (2 * c1 - 1) - (c0 - 1) * c0 * (2 * c0 - 1)) / 6
        lab = label[k]
        moments[lab, 0] += n
        moments[lab, 1] += r * n
        moments[lab, 2] += sum_c
        moments[lab, 3] += r * r * n
        moments[lab, 4] += sum_cc
        moments[lab, 5] += r * sum_c
    return label, moments


@kernel
def _runs_near_band_edge(runs, blocks, reach):
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


@kernel
def _paint_runs(runs, chosen, shape):
    """A uint8 mask (0/1) with the chosen runs set."""
    out = np.zeros(shape, np.uint8)
    for k in range(runs.shape[0]):
        if chosen[k]:
            out[runs[k, 0], runs[k, 1] : runs[k, 2]] = 1
    return out


EDGE_REACH_PX = 5
"""A stripe pixel closer than this to the band's edge may be cut by it [px]: a centre hint
reaches 4 px (one stride of level 2)."""

CLOSING_REACH_PX = 2 * (CLOSING_PX // 2)
"""Farthest a closing's result depends on the mask [px, Chebyshev]: the dilation's reach
and then the erosion's."""

if CLOSING_PX != 5 or CLOSING_REACH_PX > EDGE_REACH_PX:
    raise ImportError(f"the band closing is written for a 5 px ellipse, CLOSING_PX = {CLOSING_PX}")


@kernel
def _dilate_runs(runs, chosen, blocks, dilated) -> None:
    """Dilate the chosen runs by the 5×5 ellipse into `dilated` (uint8, frame shape): 0/1 on
    the band's blocks, the rest left as it was.

    The ellipse is rows [0,0,1,0,0], [1,1,1,1,1] ×3, [0,0,1,0,0]: a run (r, c0, c1) dilates
    to rows r − 1 … r + 1 over columns c0 − 2 … c1 + 1 and rows r ± 2 over c0 … c1 − 1,
    clipped to the frame (cv2 ignores pixels beyond it). Each painted pixel is within 2 px
    of the run, in the band when the run is more than that inside it.
    """
    height, width = dilated.shape
    zero_blocks(dilated, blocks)
    flat = dilated.ravel()
    for k in range(runs.shape[0]):
        if not chosen[k]:
            continue
        r, c0, c1 = runs[k, 0], runs[k, 1], runs[k, 2]
        wide0, wide1 = max(c0 - 2, 0), min(c1 + 2, width)
        for y in range(max(r - 1, 0), min(r + 2, height)):
            at = np.uint64(y * width + wide0)
            for i in range(wide1 - wide0):
                flat[at + np.uint64(i)] = 1
        for y in (r - 2, r + 2):
            if 0 <= y < height:
                at = np.uint64(y * width + c0)
                for i in range(c1 - c0):
                    flat[at + np.uint64(i)] = 1


@kernel
def _clipped_row_min(flat, row_at, c, width):
    """Least of flat[row_at + x] over columns x = c − 2 … c + 2 inside 0 … width − 1."""
    least = flat[row_at + np.uint64(c)]
    for x in range(max(c - 2, 0), min(c + 3, width)):
        least = min(least, flat[row_at + np.uint64(x)])
    return least


@kernel
def _erode_band(dilated, blocks, along, out) -> None:
    """Erode `dilated` by the 5×5 ellipse on the band's blocks into `out` (uint8, frame
    shape; the rest of it untouched), clipped to the frame as cv2 does.

    The ellipse is the 3×5 rectangle and the 5×1 column, so the erosion at row r is
    min(H[r − 1], H[r], H[r + 1], D[r − 2], D[r + 2]) with H the 5-px minimum of D along
    the row (D[r ± 1] and D[r] are ≥ those H). A row or column beyond the frame is replaced
    by one inside the element, which leaves the minimum as it is. `along` (BLOCK_PX + 2, N)
    holds H for rows r0 − 1 … r0 + BLOCK_PX of one block row at a time.

    D is read up to 2 px outside the band, where it may hold anything. The result is exact
    when D is right within 2 px of every band pixel whose D is 1 (`close_band` ensures it):
    at any other pixel the element's centre reads D = 0, so the minimum is 0 whatever else
    it reads.
    """
    height, width = dilated.shape
    band = block_runs(blocks)
    starts = run_starts(band, blocks.shape[0])
    d, h, o = dilated.ravel(), along.ravel(), out.ravel()
    w = np.uint64(width)
    for br in range(blocks.shape[0]):
        if starts[br] == starts[br + 1]:
            continue
        r0, r1 = br * BLOCK_PX, min(br * BLOCK_PX + BLOCK_PX, height)
        top, bottom = max(r0 - 1, 0), min(r1 + 1, height)
        for y in range(top, bottom):
            source = np.uint64(y) * w
            target = np.uint64(y - top) * w
            for k in range(starts[br], starts[br + 1]):
                c0, c1 = band[k, 1] * BLOCK_PX, min(band[k, 2] * BLOCK_PX, width)
                inner0, inner1 = max(c0, 2), max(min(c1, width - 2), max(c0, 2))
                at, to = source + np.uint64(inner0), target + np.uint64(inner0)
                for i in range(inner1 - inner0):
                    a = at + np.uint64(i)
                    left = min(d[a - np.uint64(2)], d[a - np.uint64(1)])
                    right = min(d[a + np.uint64(1)], d[a + np.uint64(2)])
                    h[to + np.uint64(i)] = min(min(left, d[a]), right)
                for c in range(c0, min(inner0, c1)):  # the frame's first two columns
                    h[target + np.uint64(c)] = _clipped_row_min(d, source, c, width)
                for c in range(inner1, c1):  # and its last two
                    h[target + np.uint64(c)] = _clipped_row_min(d, source, c, width)
        for r in range(r0, r1):
            up = np.uint64((r - 1 if r >= 1 else r) - top) * w
            mid = np.uint64(r - top) * w
            down = np.uint64((r + 1 if r + 1 < height else r) - top) * w
            up2 = np.uint64(r - 2 if r >= 2 else r) * w
            down2 = np.uint64(r + 2 if r + 2 < height else r) * w
            row = np.uint64(r) * w
            for k in range(starts[br], starts[br + 1]):
                c0, c1 = band[k, 1] * BLOCK_PX, min(band[k, 2] * BLOCK_PX, width)
                first = np.uint64(c0)
                for i in range(c1 - c0):
                    x = first + np.uint64(i)
                    rect = min(min(h[up + x], h[mid + x]), h[down + x])
                    o[row + x] = min(rect, min(d[up2 + x], d[down2 + x]))


def close_band(
    runs: np.ndarray,
    chosen: np.ndarray,
    blocks: np.ndarray,
    shape: tuple[int, int],
    *,
    near: np.ndarray | None = None,
    dilated: np.ndarray | None = None,
) -> np.ndarray:
    """`close_holes` of the chosen runs' mask, computed on the band's blocks: (M, N) bool,
    bit for bit the full-frame cv2 closing (`runs` as `_row_runs` gives them).

    On the band only when no chosen run has a pixel outside the band within
    CLOSING_REACH_PX: then the dilation is 0/1 on the band and 0 outside it, and so is the
    closing (inside the dilation). Otherwise the full-frame closing. `near` is
    `_runs_near_band_edge` at a reach ≥ CLOSING_REACH_PX px if already known; `dilated` an
    optional (M, N) uint8 scratch array whose contents do not matter.
    """
    if near is None:
        near = _runs_near_band_edge(runs, blocks, CLOSING_REACH_PX)
    if (near & chosen).any():
        return close_holes(_paint_runs(runs, chosen, shape))
    if dilated is None:
        dilated = np.empty(shape, np.uint8)
    _dilate_runs(runs, chosen, blocks, dilated)
    out = np.zeros(shape, np.uint8)
    _erode_band(dilated, blocks, np.empty((BLOCK_PX + 2, shape[1]), np.uint8), out)
    return out.view(np.bool_)


def segment_band(
    responses: tuple[np.ndarray, ...], strides: tuple[int, ...], blocks: np.ndarray, shape
) -> BandMask:
    """Stripe mask from the scales' ridge responses inside the band (as `segment_ridges`).

    Parameters
    ----------
    responses : tuple of ndarray, float32
        V of each scale on its level's grid (0 outside the band).
    strides : tuple of int
        Each level's stride 2^L.
    blocks : ndarray of bool
        The band's frame (level-0) blocks.
    shape : tuple of int
        Frame shape (M, N).

    Returns
    -------
    BandMask
    """
    runs = _stripe_runs(responses, strides, blocks, shape)
    label, moments = _label_runs(runs)
    shapes = shapes_from_moments(*moments.T)
    keep = stripe_components(shapes)
    # A component the band may have cut: one kept, or one shaped like a stripe piece. A round
    # spot (a specular reflection beside the stripe) is neither, whole or cut, so it may.
    touching = np.zeros(keep.size, bool)
    near = _runs_near_band_edge(runs, blocks, EDGE_REACH_PX)
    touching[label[near]] = True
    piece = (shapes.area_px >= MIN_COMPONENT_AREA_PX) & (shapes.elongation >= MIN_ELONGATION)
    inside = not (touching & (keep | piece)).any()
    mask = close_band(runs, keep[label], blocks, shape, near=near)
    length = float(shapes.length_px[keep].max()) if keep.any() else 0.0
    return BandMask(mask=mask, inside=inside, stripe_length_px=length)
