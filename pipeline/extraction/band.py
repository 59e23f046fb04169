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

from pipeline.extraction.blocks import BLOCK_PX, all_blocks, block_grid, pool_blocks
from pipeline.extraction.components import (
    label_extents,
    label_runs,
    paint_runs,
    row_runs,
    shapes_from_moments,
)
from pipeline.extraction.segmentation import KEEP_FRACTION

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
band. The rest of each field is left unwritten (no frame-sized memset). The frame grid's V
and C are not cleared on the ring either: V is read on the band only, and the max filter
reads C as 0 off the band's blocks."""

WIDER_MARGIN_PX = 36.0
"""Margin of the one wider band tried when a stripe component reaches the first band's
edge [px]."""

SEED_LENGTH_SHARE = 0.8
"""Share (0–1) of the longest seed region's length L that regions left out are sized
against: that region is the stripe widened by its margin, so L overstates the stripe's
length by a few margins at most."""

MAX_BAND_FRACTION = 0.4
"""A band covering more of the frame than this saves nothing: the whole frame is analysed."""


@dataclass(frozen=True, slots=True, eq=False)
class StripeBand:
    """Blocks (BLOCK_PX × BLOCK_PX of each level's grid) that may hold the stripe.

    `blocks[L]` is the bool block grid of pyramid level L, `rings[L]` the RING_BLOCKS
    blocks around it; `fraction` the share of the frame's level-0 blocks in the band;
    `left_out` (bool, the seed level's grid) those regions, None when none were;
    `left_out_px` the largest extent (bounding-box diagonal [px]) of the small seed regions
    left out of it (see `locate_band`), 0 when none were.
    """

    blocks: tuple[np.ndarray, ...]
    rings: tuple[np.ndarray, ...]
    fraction: float
    left_out_px: float = 0.0
    left_out: np.ndarray | None = None


def band_ring(blocks: np.ndarray) -> np.ndarray:
    """The blocks within RING_BLOCKS of the band's blocks, not in it."""
    size = 2 * RING_BLOCKS + 1
    near = cv2.dilate(blocks.astype(np.uint8), np.ones((size, size), np.uint8)) > 0
    return near & ~blocks


def _small_regions(band: np.ndarray, stride: int) -> tuple[np.ndarray, np.ndarray | None, float]:
    """The separate regions of a widened seed grid too small to hold a stripe piece.

    A component kept as part of the stripe is at least KEEP_FRACTION of the longest one's
    length L = √(12·λmax) (`segmentation.stripe_components`), and any pixel set of
    extent D holds none longer than √3·D. Regions with √3·D < KEEP_FRACTION · SEED_LENGTH_SHARE ·
    the longest region's L (stray spots, another part's short stripe) are left out. Returns
    the grid without them, those regions (None when none) and the largest extent D left out
    [px of the frame], which the caller checks against the stripe found (the regions are the
    seeds widened).
    """
    runs = row_runs(band.view(np.bool_), all_blocks(band.shape))
    label, moments = label_runs(runs)
    count = moments.shape[0]
    if count <= 2:
        return band, None, 0.0
    sides = label_extents(runs, label, count)
    extent = stride * np.hypot(sides[1:, 0], sides[1:, 1]).astype(np.float64)
    length = stride * shapes_from_moments(*moments.T).length_px[1:]
    small = math.sqrt(3.0) * extent < KEEP_FRACTION * SEED_LENGTH_SHARE * length.max()
    if not small.any():
        return band, None, 0.0
    dropped = np.concatenate(([False], small))[label]
    left_out = paint_runs(runs, dropped, band.shape).view(np.bool_)
    return paint_runs(runs, ~dropped, band.shape), left_out, float(extent[small].max())


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
    left_out, left_out_px = None, 0.0
    if leave_out_small:
        band, left_out, left_out_px = _small_regions(band, stride)
    flags = band.view(np.bool_)
    blocks = [pool_blocks(flags, max(BLOCK_PX // stride, 1), block_grid(level_shapes[0]))]
    for level, shape in enumerate(level_shapes[1:], start=1):
        if stride <= BLOCK_PX:
            # A level-0 block pools BLOCK_PX/stride seed cells without clipping (the seed
            # grid spans ceil(M/stride) rows), so pooling those blocks by 2^level gives
            # the same grid as pooling the seeds, from a 16× smaller one.
            blocks.append(pool_blocks(blocks[0], 2**level, block_grid(shape)))
        else:
            ratio = BLOCK_PX * 2**level // stride
            blocks.append(pool_blocks(flags, max(ratio, 1), block_grid(shape)))
    rings = tuple(band_ring(grid) for grid in blocks)
    return StripeBand(
        blocks=tuple(blocks),
        rings=rings,
        fraction=float(blocks[0].mean()),
        left_out_px=left_out_px,
        left_out=left_out,
    )
