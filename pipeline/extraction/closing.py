"""The mask's closing (paper §3.3): a dilation and an erosion by the 5×5 ellipse, on the
blocks of a band.

A closing, not a flood fill of every enclosed region: the background enclosed by a bent
stripe is not part of it. The element is written out in the kernels (`_dilate_runs`,
`_erode_band`); the OpenCV closing is the tests' reference.
"""

from __future__ import annotations

import numpy as np

from pipeline.extraction.blocks import BLOCK_PX, block_runs, run_starts, zero_blocks
from pipeline.jit import kernel

CLOSING_PX = 5
"""Diameter of the ellipse whose closing fills small holes and notches of the mask [px]:
rows [0,0,1,0,0], [1,1,1,1,1] ×3, [0,0,1,0,0] (cv2.MORPH_ELLIPSE of 5×5)."""

CLOSING_REACH_PX = 2 * (CLOSING_PX // 2)
"""Farthest a closing's result depends on the mask [px, Chebyshev]: the dilation's reach
and then the erosion's."""


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
    when D is right within 2 px of every band pixel whose D is 1 (`close_runs` ensures it):
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


def close_runs(
    runs: np.ndarray,
    chosen: np.ndarray,
    blocks: np.ndarray,
    shape: tuple[int, int],
    *,
    dilated: np.ndarray | None = None,
) -> np.ndarray:
    """The closing of the chosen runs' mask, computed on the band's blocks: (M, N) bool.

    Parameters
    ----------
    runs : ndarray of shape (K, 3), int64
        Row runs (row, first, stop) inside the band, raster order (`components.row_runs`).
    chosen : ndarray of shape (K,), bool
        The runs that make the mask. No chosen run may have a pixel outside the band within
        CLOSING_REACH_PX (the frame's edge counts as band; always so for the band of all
        blocks): then the dilation is 0/1 on the band and 0 outside it, and so is the
        closing, inside the dilation.
    blocks : ndarray of bool
        The band's blocks.
    shape : tuple of int
        Frame shape (M, N).
    dilated : ndarray of shape (M, N), uint8, optional
        Scratch array whose contents do not matter.
    """
    if dilated is None:
        dilated = np.empty(shape, np.uint8)
    _dilate_runs(runs, chosen, blocks, dilated)
    out = np.zeros(shape, np.uint8)
    _erode_band(dilated, blocks, np.empty((BLOCK_PX + 2, shape[1]), np.uint8), out)
    return out.view(np.bool_)
