"""The adaptive method's analysis written with OpenCV and NumPy: the reference the pipeline's
band kernels are checked against.

Separable filtering (cv2.sepFilter2D), the max filter of C (cv2.dilate), the bilinear
upsampling of coarser levels (cv2.resize INTER_LINEAR), 8-connected components
(cv2.connectedComponents, used by the tests directly) and the 5×5 closing
(cv2.morphologyEx). The pipeline runs none of
these; it runs its kernels over a band, the whole frame being the band of all blocks.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from pipeline.extraction.adaptive import HINT_REACH
from pipeline.extraction.closing import CLOSING_PX
from pipeline.extraction.gaussian import BORDER, GaussianDerivatives, gaussian_kernels
from pipeline.extraction.ridges import RIDGE_THRESHOLD, min_structure_squared, ridge_response
from pipeline.extraction.scalespace import (
    MAX_LEVEL,
    ScaleLevel,
    build_pyramid,
    decimated_variance,
    level_for,
)
from pipeline.extraction.steger import LineAnalysis, analyse_lines


def _filter_1d(image: np.ndarray, kernel: np.ndarray, axis: int) -> np.ndarray:
    """Convolve a float32 image along one axis (1 = x/columns, 0 = y/rows), reflect border."""
    # cv2 filters correlate; reversing the kernel turns the correlation into a convolution.
    taps = np.ascontiguousarray(kernel[::-1], dtype=np.float32)
    one = np.ones(1, dtype=np.float32)
    kernel_x, kernel_y = (taps, one) if axis == 1 else (one, taps)
    return cv2.sepFilter2D(image, cv2.CV_32F, kernel_x, kernel_y, borderType=BORDER)


def gaussian_derivatives(image: np.ndarray, sigma_px: float) -> GaussianDerivatives:
    """Ix, Iy, Ixx, Ixy, Iyy of a float32 image: three passes along x, five along y."""
    kernels = gaussian_kernels(sigma_px)
    smooth_x, d1_x, d2_x = (
        _filter_1d(image, k, axis=1) for k in (kernels.g0, kernels.g1, kernels.g2)
    )
    return GaussianDerivatives(
        sigma_px=kernels.sigma_px,
        ix=_filter_1d(d1_x, kernels.g0, axis=0),
        iy=_filter_1d(smooth_x, kernels.g1, axis=0),
        ixx=_filter_1d(d2_x, kernels.g0, axis=0),
        ixy=_filter_1d(d1_x, kernels.g1, axis=0),
        iyy=_filter_1d(smooth_x, kernels.g2, axis=0),
    )


def scale_levels(
    image: np.ndarray, sigmas_px: tuple[float, ...], *, max_level: int = MAX_LEVEL
) -> tuple[ScaleLevel, ...]:
    """Derivatives of a float32 frame at each scale, each on its pyramid level."""
    levels = [level_for(s, max_level) for s in sigmas_px]
    pyramid = build_pyramid(image, max(levels, default=0))
    out = []
    for sigma, level in zip(sigmas_px, levels, strict=True):
        residual = math.sqrt(sigma**2 - decimated_variance(level)) / 2**level
        grid = pyramid[level] if level else image
        out.append(ScaleLevel(float(sigma), level, gaussian_derivatives(grid, residual)))
    return tuple(out)


@dataclass(frozen=True, slots=True, eq=False)
class LevelFields:
    """V, C, C max-filtered and the centre hints of one scale (as `LevelResponse`)."""

    level: ScaleLevel
    response: np.ndarray
    strength: np.ndarray
    peak_strength: np.ndarray
    hints: np.ndarray


def _lines_on_grid(level: ScaleLevel, index: np.ndarray) -> LineAnalysis:
    d = level.derivatives
    first = np.float32(1 / level.stride)
    second = np.float32(1 / level.stride**2)
    return analyse_lines(
        GaussianDerivatives(
            sigma_px=level.sigma_px,
            ix=d.ix.flat[index] * first,
            iy=d.iy.flat[index] * first,
            ixx=d.ixx.flat[index] * second,
            ixy=d.ixy.flat[index] * second,
            iyy=d.iyy.flat[index] * second,
        )
    )


def _centre_hints(level: ScaleLevel, index, lines: LineAnalysis, shape) -> np.ndarray:
    near = np.abs(lines.offset_px) <= HINT_REACH * level.stride
    grid_rows, grid_cols = np.divmod(index[near], level.derivatives.ix.shape[1])
    origin = 0.5 * (level.stride - 1)
    x = grid_cols * level.stride + origin + lines.offset_px[near] * lines.nx[near]
    y = grid_rows * level.stride + origin + lines.offset_px[near] * lines.ny[near]
    rows = np.clip(np.rint(y).astype(np.int64), 0, shape[0] - 1)
    cols = np.clip(np.rint(x).astype(np.int64), 0, shape[1] - 1)
    hints = np.zeros(shape, np.uint8)
    hints[rows, cols] = 1
    return cv2.dilate(hints, np.ones((3, 3), np.uint8)).astype(bool)


def analyse_level(
    level: ScaleLevel, *, c_grey: float, shape: tuple[int, int], peak_reach_px: float
) -> LevelFields:
    """V, C = σ²|λ1|, C max-filtered over ±peak_reach_px and the hints of one scale."""
    d = level.derivatives
    norm = np.float32(level.sigma_px**2 / level.stride**2)
    trace = d.ixx + d.iyy
    s2 = (d.ixx * d.ixx + d.iyy * d.iyy + 2 * d.ixy * d.ixy) * (norm * norm)
    index = np.flatnonzero((trace < 0) & (s2 > 0.25 * min_structure_squared(c_grey)))
    lines = _lines_on_grid(level, index)
    sigma2 = np.float32(level.sigma_px**2)
    response = np.zeros(d.ix.shape, np.float32)
    strength = np.zeros(d.ix.shape, np.float32)
    response.flat[index] = ridge_response(
        lines.lambda1 * sigma2, lines.lambda2 * sigma2, c_grey=c_grey
    )
    strength.flat[index] = -sigma2 * np.minimum(lines.lambda1, 0)
    half = max(1, round(peak_reach_px / level.stride))
    peak = cv2.dilate(strength, np.ones((2 * half + 1, 2 * half + 1), np.uint8))
    hints = _centre_hints(level, index, lines, shape)
    return LevelFields(level, response, strength, peak, hints)


def upsample_to_frame(field: np.ndarray, level: int, shape: tuple[int, int]) -> np.ndarray:
    """A level-grid field resampled (bilinear, cv2 INTER_LINEAR) onto the frame grid."""
    if level == 0:
        return field
    stride = 2**level
    size = (field.shape[1] * stride, field.shape[0] * stride)
    full = cv2.resize(field, size, interpolation=cv2.INTER_LINEAR)
    return full[: shape[0], : shape[1]]


def close_holes(mask: np.ndarray) -> np.ndarray:
    """The closing by the CLOSING_PX ellipse (cv2.morphologyEx), bool."""
    disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (CLOSING_PX, CLOSING_PX))
    return cv2.morphologyEx(mask.astype(np.uint8), cv2.MORPH_CLOSE, disc).astype(bool)


def _bilinear(field: np.ndarray, stride: int, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """Bilinear values of a level field at frame pixels, pixel centres aligned, clamped."""
    if stride == 1:
        return field[rows, cols]

    def taps(index, size):
        source = (index + 0.5) / stride - 0.5
        first = np.floor(source).astype(np.int64)
        weight = source - first
        low, high = first < 0, first >= size - 1
        first = np.where(low, 0, np.where(high, size - 1, first))
        weight = np.where(low | high, 0.0, weight)
        return first, np.minimum(first + 1, size - 1), weight

    v0, v1, fv = taps(rows, field.shape[0])
    u0, u1, fu = taps(cols, field.shape[1])
    f = field.astype(np.float64)
    top = f[v0, u0] * (1 - fu) + f[v0, u1] * fu
    bottom = f[v1, u0] * (1 - fu) + f[v1, u1] * fu
    return (top * (1 - fv) + bottom * fv).astype(np.float32)


@dataclass(frozen=True, slots=True, eq=False)
class ReferenceAnalysis:
    """The whole-frame analysis: per-scale fields, V = max over scales, V > RIDGE_THRESHOLD
    and the σ map over a given mask."""

    scales: tuple[LevelFields, ...]
    response: np.ndarray
    ridges: np.ndarray
    sigma_map: np.ndarray


def analyse_frame(
    image: np.ndarray,
    sigmas_px: tuple[float, ...],
    *,
    c_grey: float,
    peak_reach_px: float,
    mask: np.ndarray,
) -> ReferenceAnalysis:
    """The adaptive method's analysis of a whole frame: the fields, V > RIDGE_THRESHOLD
    (the pixels the components are made of) and σB over `mask` (the stripe's selection is
    the pipeline's own, `segmentation.stripe_components`)."""
    frame = np.ascontiguousarray(image, np.float32)
    levels = scale_levels(frame, sigmas_px)
    scales = tuple(
        analyse_level(lv, c_grey=c_grey, shape=frame.shape, peak_reach_px=peak_reach_px)
        for lv in levels
    )
    response = np.zeros(frame.shape, np.float32)
    for scale in scales:
        np.maximum(
            response,
            upsample_to_frame(scale.response, scale.level.level, frame.shape),
            out=response,
        )
    rows, cols = np.nonzero(mask)
    best = np.zeros(rows.size, np.float32)
    index = np.full(rows.size, -1)
    for i, scale in enumerate(scales):
        c = _bilinear(scale.peak_strength, scale.level.stride, rows, cols)
        better = c > best
        best[better], index[better] = c[better], i
    sigma_map = np.zeros(frame.shape, np.float32)
    sigma_map[rows, cols] = np.asarray((0.0, *sigmas_px), np.float32)[index + 1]
    return ReferenceAnalysis(scales, response, response > RIDGE_THRESHOLD, sigma_map)
