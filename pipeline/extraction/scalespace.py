"""Gaussian scale space on a pyramid: large scales are filtered on 2×2-decimated grids.

A scale σ [px of the frame] is computed on the coarsest pyramid level L whose residual scale
σ_L = √(σ² − v_L)/2^L stays ≥ MIN_LEVEL_SIGMA_PX, where v_L is the variance the 2×2 means
already applied. The derivative fields then cost 4^L times less; values at frame pixels are
read back with bicubic interpolation, which is exact to O(h⁴) on fields this smooth.
Level 0 is the frame itself, so `max_level=0` computes every scale at full resolution.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
from numba import types
from numba.extending import overload

from pipeline.extraction.gaussian import BORDER, GaussianDerivatives
from pipeline.jit import kernel

MIN_LEVEL_SIGMA_PX = 2.0
"""Least residual σ on a decimated grid [px of that grid]: the sampled kernels stay accurate
and the derivative fields smooth enough for bicubic read-back."""

MAX_LEVEL = 2
"""Coarsest level used by default (4× decimation)."""


@dataclass(frozen=True, slots=True, eq=False)
class ScaleLevel:
    """Derivatives of the frame at scale `sigma_px`, stored on pyramid level `level`.

    `derivatives` are in units of that level's grid; frame pixel (r, c) sits at level
    coordinates ((r − o)/s, (c − o)/s) with stride s = 2^level and o = (s − 1)/2.
    """

    sigma_px: float
    level: int
    derivatives: GaussianDerivatives

    @property
    def stride(self) -> int:
        return 2**self.level

    def to_level(self, coord_px: np.ndarray) -> np.ndarray:
        """Frame coordinate [px] → coordinate on this level's grid (float32)."""
        return ((coord_px - 0.5 * (self.stride - 1)) / self.stride).astype(np.float32)


def decimated_variance(level: int) -> float:
    """Variance [px²] the 2×2 means of `level` pyramid steps add (a 2-tap mean: 1/4 per step)."""
    return 0.25 * (4**level - 1) / 3


def level_for(sigma_px: float, max_level: int) -> int:
    """Coarsest level ≤ max_level keeping the residual σ ≥ MIN_LEVEL_SIGMA_PX."""
    level = 0
    while level < max_level:
        nxt = level + 1
        residual = math.sqrt(max(sigma_px**2 - decimated_variance(nxt), 0)) / 2**nxt
        if residual < MIN_LEVEL_SIGMA_PX:
            break
        level = nxt
    return level


@kernel
def halve(image):
    """2×2 means of an image with even sides, as float32 (cv2 INTER_AREA at exactly ½)."""
    rows, cols = image.shape[0] // 2, image.shape[1] // 2
    out = np.empty((rows, cols), np.float32)
    for r in range(rows):
        for c in range(cols):
            total = (
                np.float32(image[2 * r, 2 * c])
                + np.float32(image[2 * r, 2 * c + 1])
                + np.float32(image[2 * r + 1, 2 * c])
                + np.float32(image[2 * r + 1, 2 * c + 1])
            )
            out[r, c] = total * np.float32(0.25)
    return out


def build_pyramid(image: np.ndarray, levels: int) -> list[np.ndarray]:
    """The frame padded (reflect) to a multiple of 2^levels, and its 2×2-mean decimations.

    `image` may be of any real dtype; the decimated levels are float32.
    """
    stride = 2**levels
    pad_rows = -image.shape[0] % stride
    pad_cols = -image.shape[1] % stride
    base = (
        cv2.copyMakeBorder(image, 0, pad_rows, 0, pad_cols, BORDER)
        if pad_rows or pad_cols
        else image
    )
    pyramid = [base]
    for _ in range(levels):
        pyramid.append(halve(pyramid[-1]))
    return pyramid


def level_shapes(shape: tuple[int, int], levels: int) -> tuple[tuple[int, int], ...]:
    """Grid shape of pyramid levels 0..levels (level 0 is the frame itself, unpadded)."""
    stride = 2**levels
    padded = (-(-shape[0] // stride) * stride, -(-shape[1] // stride) * stride)
    return (shape, *((padded[0] >> k, padded[1] >> k) for k in range(1, levels + 1)))


@kernel
def _keys_near(d: float) -> float:
    """Keys cubic convolution weight (a = −1/2) of a tap 0 ≤ d ≤ 1 grid steps away."""
    return (1.5 * d - 2.5) * d * d + 1.0


@kernel
def _keys_far(d: float) -> float:
    """Keys cubic convolution weight (a = −1/2) of a tap 1 ≤ d ≤ 2 grid steps away (0 at 2)."""
    return ((-0.5 * d + 2.5) * d - 4.0) * d + 2.0


@kernel
def keys_weights(fraction: float) -> tuple[float, float, float, float]:
    """Keys weights of the 4 taps at −1, 0, 1, 2 grid steps from a point `fraction` past
    tap 0 (0 ≤ fraction ≤ 1).

    Each tap's distance lies in one piece of the kernel, so no branch picks the piece: the
    reads along a line (`normal_fit`, `widths`) run about 1.7× faster than with a branch
    per tap. Where a distance is 1 or 2 both pieces give 0.
    """
    return (
        _keys_far(fraction + 1),
        _keys_near(fraction),
        _keys_near(1 - fraction),
        _keys_far(2 - fraction),
    )


@kernel
def fold_index(index: int, size: int) -> int:
    """An index folded into [0, size) as cv2.BORDER_REFLECT (edge pixel repeated), as
    often as it takes: the one BORDER mode of the pipeline, index by index."""
    if size == 1:
        return 0
    while index < 0 or index >= size:
        index = -index - 1 if index < 0 else 2 * size - index - 1
    return index


@kernel
def cubic_taps(u: float, v: float, height: int, width: int):
    """Rows, columns (reflected) and Keys weights of the 4 × 4 taps around (u, v)."""
    u0 = np.floor(u)
    v0 = np.floor(v)
    fu, fv = u - u0, v - v0
    iu, iv = int(u0), int(v0)
    wu, wv = keys_weights(fu), keys_weights(fv)
    cols = (
        fold_index(iu - 1, width),
        fold_index(iu, width),
        fold_index(iu + 1, width),
        fold_index(iu + 2, width),
    )
    rows = (
        fold_index(iv - 1, height),
        fold_index(iv, height),
        fold_index(iv + 1, height),
        fold_index(iv + 2, height),
    )
    return rows, cols, wv, wu


@kernel
def interior_taps(u: float, v: float):
    """`cubic_taps` of a point whose 4 × 4 taps all lie inside the grid: no index folding,
    unsigned indices (no negative-index wrap-around test)."""
    u0 = np.floor(u)
    v0 = np.floor(v)
    c, r = np.uint64(u0) - np.uint64(1), np.uint64(v0) - np.uint64(1)
    one, two, three = np.uint64(1), np.uint64(2), np.uint64(3)
    rows = (r, r + one, r + two, r + three)
    cols = (c, c + one, c + two, c + three)
    return rows, cols, keys_weights(v - v0), keys_weights(u - u0)


EIGHT_BIT_GREYS = np.arange(256, dtype=np.float64)
"""Grey level g as float64 at index g: a tap of an 8-bit frame is read from this table (one
load) instead of converted (an int-to-float conversion per tap, most of the cost of reading
the frame along the normals in `normal_fit`: 16 taps per sample)."""


def tap_value(field, r, c):
    """field[r, c] as the interpolation sums read it: through EIGHT_BIT_GREYS for a uint8
    field, as it is otherwise (numba only: the compiled kernels inline it)."""
    raise NotImplementedError


@overload(tap_value, inline="always")
def _tap_value(field, r, c):  # noqa: ARG001 (the stub's signature)
    """`tap_value` for numba, by the field's element type."""
    if field.dtype == types.uint8:
        return lambda field, r, c: EIGHT_BIT_GREYS[field[r, c]]
    return lambda field, r, c: field[r, c]


@kernel
def cubic_at(field, rows, cols, wv, wu) -> float:
    """Keys cubic convolution of `field` from its taps (see `cubic_taps`)."""
    total = 0.0
    for i in range(4):
        r = rows[i]
        total += wv[i] * (
            wu[0] * tap_value(field, r, cols[0])
            + wu[1] * tap_value(field, r, cols[1])
            + wu[2] * tap_value(field, r, cols[2])
            + wu[3] * tap_value(field, r, cols[3])
        )
    return total


@kernel
def _interpolate_cubic(fields, u, v, outs) -> None:
    height, width = fields[0].shape
    for k in range(u.size):
        rows, cols, wv, wu = cubic_taps(u[k], v[k], height, width)
        for f in range(len(fields)):
            outs[f][k] = cubic_at(fields[f], rows, cols, wv, wu)


@kernel
def level_coordinate(coord_px: float, stride: int) -> np.float32:
    """Frame coordinate [px] → coordinate on a level grid of stride 2^L, float32 as
    `ScaleLevel.to_level`."""
    return np.float32((coord_px - 0.5 * (stride - 1)) / stride)


@kernel
def _cubic_at_pixels(fields, stride, rows, cols, scales, outs) -> None:
    """`_interpolate_cubic` at frame pixels (rows, cols) of a level with stride 2^L > 1,
    each field's value (float32) times its `scales[f]` (float32).

    A frame pixel's position on the level grid has a fraction that depends only on the
    pixel modulo the stride, so the Keys weights come from a table of `stride` entries;
    taps wholly inside the grid are indexed directly. The sums are `cubic_at`'s.
    """
    height, width = fields[0].shape
    origin = 0.5 * (stride - 1)
    weights = np.empty((stride, 4))
    for residue in range(stride):
        u = (residue - origin) / stride
        weights[residue] = keys_weights(u - np.floor(u))
    for k in range(rows.size):
        r, c = rows[k], cols[k]
        iu = int(np.floor((c - origin) / stride))
        iv = int(np.floor((r - origin) / stride))
        if not (1 <= iu < width - 2 and 1 <= iv < height - 2):
            u, v = level_coordinate(c, stride), level_coordinate(r, stride)
            taps = cubic_taps(np.float64(u), np.float64(v), height, width)
        else:
            wu, wv = weights[c % stride], weights[r % stride]
            taps = (
                (iv - 1, iv, iv + 1, iv + 2),
                (iu - 1, iu, iu + 1, iu + 2),
                (wv[0], wv[1], wv[2], wv[3]),
                (wu[0], wu[1], wu[2], wu[3]),
            )
        for f in range(len(fields)):
            outs[f][k] = np.float32(cubic_at(fields[f], *taps)) * scales[f]


@kernel
def _at_pixels(fields, rows, cols, outs) -> None:
    """outs[f][k] = fields[f][rows[k], cols[k]] (one pass for all fields)."""
    for k in range(rows.size):
        r, c = rows[k], cols[k]
        for f in range(len(fields)):
            outs[f][k] = fields[f][r, c]


def interpolate_cubic_fields(
    fields: tuple[np.ndarray, ...], u: np.ndarray, v: np.ndarray
) -> tuple[np.ndarray, ...]:
    """`interpolate_cubic` of several fields of one shape at the same coordinates."""
    outs = tuple(np.empty(np.size(u), np.float32) for _ in fields)
    _interpolate_cubic(
        tuple(fields),
        np.ascontiguousarray(u, np.float64).ravel(),
        np.ascontiguousarray(v, np.float64).ravel(),
        outs,
    )
    return tuple(out.reshape(np.shape(u)) for out in outs)


def interpolate_cubic(field: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Keys cubic convolution of a 2-D field at grid coordinates (u = column, v = row).

    Parameters
    ----------
    field : ndarray of shape (H, W), float32
    u, v : ndarray of shape (K,)
        Coordinates on the field's grid; outside it the field is reflected (BORDER).

    Returns
    -------
    ndarray of shape (K,), float32

    Notes
    -----
    Keys' kernel with a = −1/2 is the one choice that reproduces quadratics exactly
    (third-order accurate); OpenCV's INTER_CUBIC uses a = −3/4, which does not even
    reproduce a linear ramp.
    """
    return interpolate_cubic_fields((field,), u, v)[0]


def sample_derivatives(
    level: ScaleLevel, rows: np.ndarray, cols: np.ndarray
) -> GaussianDerivatives:
    """Ix, Iy, Ixx, Ixy, Iyy at frame pixels, in frame units (float32, shape (K,)).

    Level 0 is read directly; coarser levels by Keys cubic convolution, reflect border,
    and scaled to frame units in the same pass (level 0 is in frame units already).
    """
    d = level.derivatives
    fields = (d.ix, d.iy, d.ixx, d.ixy, d.iyy)
    outs = tuple(np.empty(np.size(rows), np.float32) for _ in fields)
    pixels = (np.asarray(rows, np.int64), np.asarray(cols, np.int64))
    if level.level == 0:
        _at_pixels(fields, *pixels, outs)
    else:
        first, second = 1 / level.stride, 1 / level.stride**2
        scales = np.array([first, first, second, second, second], np.float32)
        _cubic_at_pixels(fields, level.stride, *pixels, scales, outs)
    ix, iy, ixx, ixy, iyy = outs
    return GaussianDerivatives(sigma_px=level.sigma_px, ix=ix, iy=iy, ixx=ixx, ixy=ixy, iyy=iyy)


@kernel
def linear_tap(index: int, stride: int, size: int) -> tuple[int, int, float]:
    """Taps and weight of frame index `index` on a level grid of `size` nodes, stride
    2^L: the value is g[first]·(1 − w) + g[second]·w, pixel centres aligned and clamped at
    the edges (cv2.resize INTER_LINEAR)."""
    source = (index + 0.5) / stride - 0.5
    first = int(np.floor(source))
    weight = source - first
    if first < 0:
        first, weight = 0, 0.0
    if first >= size - 1:
        first, weight = size - 1, 0.0
    return first, min(first + 1, size - 1), weight


@kernel
def column_taps(fields, strides, width):
    """`linear_tap` of frame columns 0 … width − 1 on each field's grid: first, second
    (int64) and weight, arrays (len(fields), width); rows of stride 1 are 0."""
    levels = len(fields)
    first = np.zeros((levels, width), np.int64)
    second = np.zeros((levels, width), np.int64)
    weight = np.zeros((levels, width))
    for i in range(levels):
        if strides[i] > 1:
            for c in range(width):
                first[i, c], second[i, c], weight[i, c] = linear_tap(
                    c, strides[i], fields[i].shape[1]
                )
    return first, second, weight


@kernel
def blend(field, v0: int, v1: int, fv: float, u0: int, u1: int, fu: float) -> float:
    """Bilinear value of `field` between rows v0, v1 and columns u0, u1 with weights fv, fu
    of the second row and column (`linear_tap`, `bilinear_at`): the one bilinear read of
    the pipeline. An integer field is read as float64."""
    top = field[v0, u0] * (1 - fu) + field[v0, u1] * fu
    bottom = field[v1, u0] * (1 - fu) + field[v1, u1] * fu
    return top * (1 - fv) + bottom * fv


@kernel
def bilinear_at(field, u: float, v: float, inside: bool) -> float:
    """Bilinear value of `field` at grid coordinates (u, v) [px] (`blend`): reflect border
    (`fold_index`, as often as it takes) unless the caller knows all four taps lie
    `inside` the grid. An integer field is read as float64."""
    height, width = field.shape
    u_floor, v_floor = np.floor(u), np.floor(v)
    u0, v0 = int(u_floor), int(v_floor)
    if inside:
        u1, v1 = u0 + 1, v0 + 1
    else:
        u1, v1 = fold_index(u0 + 1, width), fold_index(v0 + 1, height)
        u0, v0 = fold_index(u0, width), fold_index(v0, height)
    return blend(field, v0, v1, v - v_floor, u0, u1, u - u_floor)


@kernel
def _bilinear_points(field, u, v, out) -> None:
    for k in range(u.size):
        out[k] = bilinear_at(field, u[k], v[k], False)


def bilinear_points(field: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """`bilinear_at` of a 2-D field at many grid coordinates (u = column, v = row) [px],
    reflect border.

    Parameters
    ----------
    field : ndarray of shape (H, W), real
    u, v : ndarray, same shape
        Coordinates on the field's grid [px].

    Returns
    -------
    ndarray of the shape of `u`, float64
    """
    u = np.ascontiguousarray(u, np.float64)
    v = np.ascontiguousarray(v, np.float64)
    out = np.empty(u.size)
    _bilinear_points(field, u.ravel(), v.ravel(), out)
    return out.reshape(u.shape)
