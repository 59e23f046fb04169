"""The stripe band: where in a frame the stripe can be, as blocks of every pyramid level.

The coarsest scale's ridge response, which the adaptive method computes anyway, is cheap on
its decimated grid and sees every part of a wheel stripe (narrow ones too: σ²-normalised,
a 5 px stripe at σ 12 px still has S ≫ c). Where it exceeds BAND_SEED_RESPONSE the stripe
may be; the band is that region widened by BAND_MARGIN_PX.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from pipeline.extraction.segmentation import KEEP_FRACTION, component_shapes
from pipeline.jit import kernel

BLOCK_PX = 8
"""Side of a band block [px of its level]."""

BAND_SEED_RESPONSE = 0.1
"""Coarsest-scale V above which a pixel may belong to a stripe (the mask needs V > 0.5 at
some scale). Stray spots reach it too (up to V ≈ 1 on the 1600×1200 clutter frame); their
separate, small regions are left out by size (`locate_band`)."""

BAND_MARGIN_PX = 12.0
"""Widening of the seeds [px of the frame]. The seeds already span a stripe's width (σ3's
response reaches wider than any scale's V > 0.5); the margin keeps the mask EDGE_REACH_PX
inside the band, with room for the max filter of C and the width search. Measured on the
issue-3 cases and 1600×1200 frames: 12 px keeps every frame on the band path with the same
mask and centres as the full frame, 8 px sends some to the full frame."""

RING_BLOCKS = 2
"""The band path's fields hold their values on the band and 0 on this many blocks around
it, and nothing reads further: the width search (13 px at σ1), the bilinear and cubic reads
and the max filter of C (10 px) all stay within 2 blocks of a mask EDGE_REACH_PX inside the
band. The rest of each field is left unwritten (no frame-sized memset)."""

WIDER_MARGIN_PX = 36.0
"""Margin of the one wider band tried when a stripe component reaches the first band's
edge [px]."""

SEED_LENGTH_SHARE = 0.8
"""Share (0–1) of the longest seed region's length L that regions left out are sized
against: that region is the stripe widened by its margin, so L overstates the stripe's
length by a few margins at most."""

MAX_BAND_FRACTION = 0.4
"""A band covering more of the frame than this saves nothing: the full-frame path runs."""


@dataclass(frozen=True, slots=True, eq=False)
class StripeBand:
    """Blocks (BLOCK_PX × BLOCK_PX of each level's grid) that may hold the stripe.

    `blocks[L]` is the bool block grid of pyramid level L, `rings[L]` the RING_BLOCKS
    blocks around it; `fraction` the share of the frame's level-0 blocks in the band;
    `left_out_px` the largest extent (bounding-box diagonal [px]) of the small seed regions
    left out of it (see `locate_band`), 0 when none were.
    """

    blocks: tuple[np.ndarray, ...]
    rings: tuple[np.ndarray, ...]
    fraction: float
    left_out_px: float = 0.0


def band_ring(blocks: np.ndarray) -> np.ndarray:
    """The blocks within RING_BLOCKS of the band's blocks, not in it."""
    size = 2 * RING_BLOCKS + 1
    near = cv2.dilate(blocks.astype(np.uint8), np.ones((size, size), np.uint8)) > 0
    return near & ~blocks


@kernel
def block_runs(blocks):
    """Runs of consecutive True blocks along each block row: rows of (block_row, first, stop)."""
    runs = np.empty((blocks.size // 2 + blocks.shape[0], 3), np.int64)
    count = 0
    for br in range(blocks.shape[0]):
        bc = 0
        while bc < blocks.shape[1]:
            if not blocks[br, bc]:
                bc += 1
                continue
            start = bc
            while bc < blocks.shape[1] and blocks[br, bc]:
                bc += 1
            runs[count, 0], runs[count, 1], runs[count, 2] = br, start, bc
            count += 1
    return runs[:count]


@kernel
def run_starts(runs, rows):
    """Where each of `rows` block rows begins in `runs` (sorted by row): (rows + 1,) int64,
    so the runs of block row br are runs[starts[br]:starts[br + 1]]."""
    return np.searchsorted(runs[:, 0], np.arange(rows + 1))


@kernel
def zero_blocks(field, blocks) -> None:
    """Set the pixels of the given blocks to 0."""
    height, width = field.shape
    for br, first, stop in block_runs(blocks):
        c0, c1 = first * BLOCK_PX, min(stop * BLOCK_PX, width)
        for r in range(br * BLOCK_PX, min(br * BLOCK_PX + BLOCK_PX, height)):
            field[r, c0:c1] = 0


def block_grid(shape: tuple[int, int]) -> tuple[int, int]:
    """Shape of the block grid over an image of `shape` (rows, columns)."""
    return math.ceil(shape[0] / BLOCK_PX), math.ceil(shape[1] / BLOCK_PX)


@kernel
def _pool(band, ratio, rows, cols):
    out = np.zeros((rows, cols), np.bool_)
    for r in range(band.shape[0]):
        for c in range(band.shape[1]):
            if band[r, c]:
                out[min(r // ratio, rows - 1), min(c // ratio, cols - 1)] = True
    return out


def pool_blocks(flags: np.ndarray, ratio: int, grid: tuple[int, int]) -> np.ndarray:
    """Blocks of `ratio` × `ratio` pixels of `flags` that hold any True pixel (bool `grid`)."""
    return _pool(flags, ratio, grid[0], grid[1])


@kernel
def blocks_holding(flags, blocks):
    """Which of the band's blocks hold a True pixel of `flags` (same grid as `blocks`)."""
    height, width = flags.shape
    out = np.zeros(blocks.shape, np.bool_)
    for br, first, stop in block_runs(blocks):
        for bc in range(first, stop):
            r1 = min(br * BLOCK_PX + BLOCK_PX, height)
            c1 = min(bc * BLOCK_PX + BLOCK_PX, width)
            out[br, bc] = flags[br * BLOCK_PX : r1, bc * BLOCK_PX : c1].any()
    return out


@kernel
def _label_sides(labels, count):
    """Bounding-box height and width − 1 of each label 1..count − 1: (count, 2) int64, row 0
    (the background) unset."""
    low = np.full((count, 2), labels.size, np.int64)
    high = np.zeros((count, 2), np.int64)
    for r in range(labels.shape[0]):
        for c in range(labels.shape[1]):
            k = labels[r, c]
            if k:
                low[k, 0], high[k, 0] = min(low[k, 0], r), max(high[k, 0], r)
                low[k, 1], high[k, 1] = min(low[k, 1], c), max(high[k, 1], c)
    return high - low


@kernel
def _without(band, labels, drop):
    """`band` with the pixels of the labels marked in `drop` cleared."""
    out = band.copy()
    for r in range(band.shape[0]):
        for c in range(band.shape[1]):
            if drop[labels[r, c]]:
                out[r, c] = 0
    return out


def _small_regions(band: np.ndarray, stride: int) -> tuple[np.ndarray, float]:
    """The separate regions of a widened seed grid too small to hold a stripe piece.

    A component kept as part of the stripe is at least KEEP_FRACTION of the longest one's
    length L = √(12·λmax) (`segmentation.stripe_components`), and any pixel set of
    extent D holds none longer than √3·D. Regions with √3·D < KEEP_FRACTION · SEED_LENGTH_SHARE ·
    the longest region's L (stray spots, another part's short stripe) are left out. Returns
    the grid without them and the largest extent D left out [px of the frame], which the
    caller checks against the stripe's actual length (the regions are the seeds widened).
    """
    count, labels = cv2.connectedComponents(band, connectivity=8)
    if count <= 2:
        return band, 0.0
    sides = _label_sides(labels, count)
    extent = stride * np.hypot(sides[1:, 0] + 1.0, sides[1:, 1] + 1.0)
    length = stride * component_shapes(labels, count).length_px[1:]
    small = math.sqrt(3.0) * extent < KEEP_FRACTION * SEED_LENGTH_SHARE * length.max()
    if not small.any():
        return band, 0.0
    return _without(band, labels, np.concatenate(([False], small))), float(extent[small].max())


def locate_band(
    seed_response: np.ndarray,
    seed_level: int,
    level_shapes: tuple[tuple[int, int], ...],
    *,
    margin_px: float = BAND_MARGIN_PX,
    leave_out_small: bool = True,
) -> StripeBand:
    """The stripe band from the coarsest scale's ridge response.

    Parameters
    ----------
    seed_response : ndarray of shape (H, W), float32
        V of the coarsest scale on its pyramid level's grid.
    seed_level : int
        That pyramid level (stride 2^seed_level, ≥ 1).
    level_shapes : tuple of (rows, cols)
        Grid shape of every pyramid level, level 0 (the frame) first.
    margin_px : float
        Widening of the seeds [px of the frame].
    leave_out_small : bool
        Leave out separate seed regions too small to hold a piece of the stripe (see
        `_small_regions`).

    Returns
    -------
    StripeBand
    """
    stride = 2**seed_level
    seeds = (seed_response > BAND_SEED_RESPONSE).astype(np.uint8)
    reach = max(1, math.ceil(margin_px / stride))
    disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * reach + 1, 2 * reach + 1))
    band = cv2.dilate(seeds, disc)
    left_out = 0.0
    if leave_out_small:
        band, left_out = _small_regions(band, stride)
    flags = band.view(np.bool_)
    blocks = []
    for level, shape in enumerate(level_shapes):
        ratio = BLOCK_PX * 2**level // stride
        blocks.append(pool_blocks(flags, max(ratio, 1), block_grid(shape)))
    rings = tuple(band_ring(grid) for grid in blocks)
    return StripeBand(
        blocks=tuple(blocks),
        rings=rings,
        fraction=float(blocks[0].mean()),
        left_out_px=left_out,
    )


@kernel
def band_pixels(flags, blocks):
    """Rows and columns of the True pixels of `flags` inside the band's blocks, raster order."""
    height, width = flags.shape
    runs = block_runs(blocks)
    starts = run_starts(runs, blocks.shape[0])
    most = int(blocks.sum()) * BLOCK_PX * BLOCK_PX
    rows = np.empty(most, np.int64)
    cols = np.empty(most, np.int64)
    count = 0
    for r in range(height):
        br = r // BLOCK_PX
        for k in range(starts[br], starts[br + 1]):
            for c in range(runs[k, 1] * BLOCK_PX, min(runs[k, 2] * BLOCK_PX, width)):
                if flags[r, c]:
                    rows[count] = r
                    cols[count] = c
                    count += 1
    return rows[:count].copy(), cols[:count].copy()
