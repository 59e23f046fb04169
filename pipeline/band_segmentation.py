"""Stripe mask inside the band: V = max over scales, threshold, 8-connected components,
the stripe's components, closing; as `segment_ridges`, on the band's pixels only."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pipeline.band import BLOCK_PX, band_pixels
from pipeline.jit import kernel
from pipeline.ridges import RIDGE_THRESHOLD
from pipeline.segmentation import (
    MIN_COMPONENT_AREA_PX,
    close_holes,
    shapes_from_moments,
    stripe_components,
)


@dataclass(frozen=True, slots=True, eq=False)
class BandMask:
    """The stripe mask found inside a band.

    `mask` (M, N) bool is the closed stripe mask; `inside` is False when a component that is
    or could be part of the stripe comes within EDGE_REACH_PX of the band's edge, where the
    band may have cut it (the full-frame path must then decide).
    """

    mask: np.ndarray
    inside: bool


@kernel
def _upsampled(field, stride, r, c) -> float:
    """Bilinear value of a level field at frame pixel (r, c), as cv2.resize INTER_LINEAR."""
    height, width = field.shape
    sy = (r + 0.5) / stride - 0.5
    sx = (c + 0.5) / stride - 0.5
    y0 = int(np.floor(sy))
    x0 = int(np.floor(sx))
    fy = sy - y0
    fx = sx - x0
    if y0 < 0:
        y0, fy = 0, 0.0
    if y0 >= height - 1:
        y0, fy = height - 1, 0.0
    if x0 < 0:
        x0, fx = 0, 0.0
    if x0 >= width - 1:
        x0, fx = width - 1, 0.0
    y1 = min(y0 + 1, height - 1)
    x1 = min(x0 + 1, width - 1)
    top = field[y0, x0] * (1 - fx) + field[y0, x1] * fx
    bottom = field[y1, x0] * (1 - fx) + field[y1, x1] * fx
    return top * (1 - fy) + bottom * fy


@kernel
def _stripe_binary(responses, strides, blocks, shape):
    """V = max over scales > RIDGE_THRESHOLD on the band's frame pixels."""
    height, width = shape
    binary = np.zeros((height, width), np.bool_)
    for br in range(blocks.shape[0]):
        for bc in range(blocks.shape[1]):
            if not blocks[br, bc]:
                continue
            for r in range(br * BLOCK_PX, min(br * BLOCK_PX + BLOCK_PX, height)):
                for c in range(bc * BLOCK_PX, min(bc * BLOCK_PX + BLOCK_PX, width)):
                    for i in range(len(responses)):
                        field = responses[i]
                        v = field[r, c] if strides[i] == 1 else _upsampled(field, strides[i], r, c)
                        if v > RIDGE_THRESHOLD:
                            binary[r, c] = True
                            break
    return binary


@kernel
def _find(parent, p):
    while parent[p] != p:
        parent[p] = parent[parent[p]]
        p = parent[p]
    return p


@kernel
def _label_components(width, rows, cols, height):
    """8-connected components of the pixels (rows, cols), given in raster order.

    Union-find with the smaller flat index as root, so a component's root is its first pixel.
    Returns each pixel's label (1..K−1) and `moments[k]`: the area and the sums of r, c, r²,
    c², r·c of component k (row 0, the background, stays 0).
    """
    parent = np.empty(height * width, np.int64)
    flat = rows * width + cols
    for p in flat:
        parent[p] = p
    present = np.zeros(height * width, np.bool_)
    present[flat] = True
    for k in range(flat.size):
        r, c, p = rows[k], cols[k], flat[k]
        for dr, dc in ((-1, -1), (-1, 0), (-1, 1), (0, -1)):
            rr, cc = r + dr, c + dc
            if rr >= 0 and 0 <= cc < width and present[rr * width + cc]:
                a, b = _find(parent, p), _find(parent, rr * width + cc)
                if a != b:
                    parent[max(a, b)] = min(a, b)
    root = np.empty(flat.size, np.int64)
    for k in range(flat.size):
        root[k] = _find(parent, flat[k])
    label = np.empty(flat.size, np.int64)
    count = 1
    for k in range(flat.size):
        if root[k] == flat[k]:
            parent[flat[k]] = count  # roots come first in raster order: label them in turn
            count += 1
        label[k] = parent[root[k]]
    moments = np.zeros((count, 6))
    for k in range(flat.size):
        lab = label[k]
        r, c = float(rows[k]), float(cols[k])
        moments[lab, 0] += 1
        moments[lab, 1] += r
        moments[lab, 2] += c
        moments[lab, 3] += r * r
        moments[lab, 4] += c * c
        moments[lab, 5] += r * c
    return label, moments


EDGE_REACH_PX = 5
"""A stripe pixel closer than this to the band's edge may be cut by it [px]: a centre hint
reaches 4 px (one stride of level 2)."""


@kernel
def _near_band_edge(rows, cols, blocks, reach):
    """Whether each pixel has a pixel outside the band within `reach` (beyond the frame: band).

    `reach` < BLOCK_PX, so the square of side 2·reach + 1 meets at most 2 × 2 blocks and its
    corners tell.
    """
    out = np.zeros(rows.size, np.bool_)
    last_r, last_c = blocks.shape[0] - 1, blocks.shape[1] - 1
    for k in range(rows.size):
        for dr in (-reach, reach):
            for dc in (-reach, reach):
                r, c = rows[k] + dr, cols[k] + dc
                br = min(max(r, 0) // BLOCK_PX, last_r)
                bc = min(max(c, 0) // BLOCK_PX, last_c)
                if not blocks[br, bc]:
                    out[k] = True
    return out


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
    binary = _stripe_binary(responses, strides, blocks, shape)
    rows, cols = band_pixels(binary, blocks)
    label, moments = _label_components(shape[1], rows, cols, shape[0])
    shapes = shapes_from_moments(*moments.T)
    keep = stripe_components(shapes)
    # A component the band may have cut: kept, or large enough to be kept whole.
    touching = np.zeros(keep.size, bool)
    touching[label[_near_band_edge(rows, cols, blocks, EDGE_REACH_PX)]] = True
    inside = not (touching & (keep | (shapes.area_px >= MIN_COMPONENT_AREA_PX))).any()
    kept = keep[label]
    stripe = np.zeros(shape, bool)
    stripe[rows[kept], cols[kept]] = True
    return BandMask(mask=close_holes(stripe), inside=inside)
