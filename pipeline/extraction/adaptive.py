"""The multi-scale adaptive analysis: scales from the width range, V = max over scales, σB."""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from pipeline.extraction.band import BLOCK_PX, block_runs, run_starts
from pipeline.extraction.gaussian import GaussianDerivatives
from pipeline.extraction.ridges import min_structure_squared, ridge_response
from pipeline.extraction.scalespace import (
    MAX_LEVEL,
    ScaleLevel,
    blend,
    column_taps,
    linear_tap,
    sample_bilinear,
    sample_derivatives,
    scale_levels,
    upsample_to_frame,
)
from pipeline.extraction.steger import LineAnalysis, analyse_lines
from pipeline.jit import kernel

HINT_REACH = 1.0
"""A level-grid pixel hints at a centre when its Taylor step is within this many level
pixels; the frame pixel holding the predicted centre and its 8 neighbours become candidates."""


@dataclass(frozen=True, slots=True, eq=False)
class LevelResponse:
    """What one scale says about the frame: V, ridge-peak strength and centre hints.

    `response` (float32, level grid) is V, 0 where λ1 ≥ 0 or the structure is too weak to
    matter; `peak_strength` (float32, level grid) is C = σ²|λ1| [grey levels] max-filtered
    across the stripe, the value at the ridge; `hints` (bool, frame grid) marks frame pixels
    that may hold a centre at this scale.
    """

    level: ScaleLevel
    response: np.ndarray
    peak_strength: np.ndarray
    hints: np.ndarray


@dataclass(frozen=True, slots=True, eq=False)
class MultiScaleAnalysis:
    """Scale space of a frame and its multi-scale ridge response.

    `scales` holds one LevelResponse per scale σ1..σS; `response` (M, N) float32 is
    V(σA) = max over scales of the ridge response, in [0, 1).
    """

    sigmas_px: tuple[float, ...]
    scales: tuple[LevelResponse, ...]
    response: np.ndarray

    @property
    def levels(self) -> tuple[ScaleLevel, ...]:
        return tuple(s.level for s in self.scales)


@dataclass(frozen=True, slots=True, eq=False)
class ScaleChoice:
    """The best scale σB per pixel and the line analysis there; arrays (K,).

    `scale_index` (int64) indexes the scales, −1 where no scale has λ1 < 0; `strength` is
    σB²|λ1(σB)| [grey levels]; `lines` the line analysis at σB.
    """

    scale_index: np.ndarray
    strength: np.ndarray
    lines: LineAnalysis


def stripe_scales(width_min_px: float, width_max_px: float) -> tuple[float, float, float]:
    """The three scales σ1 = wmin/√3, σ2 = (wmin+wmax)/(2√3), σ3 = wmax/√3 [px] (paper §3.2)."""
    root3 = math.sqrt(3.0)
    return (
        width_min_px / root3,
        (width_min_px + width_max_px) / (2 * root3),
        width_max_px / root3,
    )


def _frame_units(level: ScaleLevel, index: np.ndarray) -> GaussianDerivatives:
    """Derivatives at flat level-grid indices, converted to frame units."""
    d = level.derivatives
    first = np.float32(1 / level.stride)
    second = np.float32(1 / level.stride**2)
    return GaussianDerivatives(
        sigma_px=level.sigma_px,
        ix=d.ix.flat[index] * first,
        iy=d.iy.flat[index] * first,
        ixx=d.ixx.flat[index] * second,
        ixy=d.ixy.flat[index] * second,
        iyy=d.iyy.flat[index] * second,
    )


def _centre_hints(level: ScaleLevel, index: np.ndarray, lines: LineAnalysis, shape) -> np.ndarray:
    """Frame pixels near centres predicted from level-grid pixels (bool (M, N))."""
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
) -> LevelResponse:
    """Ridge response, ridge-peak strength and centre hints of one scale.

    Parameters
    ----------
    level : ScaleLevel
        Derivatives of the scale.
    c_grey : float
        Structure constant of the ridge response [grey levels].
    shape : tuple of int
        Frame shape (M, N).
    peak_reach_px : float
        Half-size [px] of the square over which C = σ²|λ1| is max-filtered: about half the
        widest stripe, so every pixel of a stripe's cross-section sees the value at its ridge.

    Notes
    -----
    V > RIDGE_THRESHOLD needs λ1 < 0 (so Ixx + Iyy < 0) and S² = σ⁴(Ixx² + 2Ixy² + Iyy²) above
    `min_structure_squared`; S² needs no eigen-decomposition, so the eigen-analysis runs only
    where the trace is negative and S² exceeds a quarter of that bound (weaker pixels can
    neither pass the threshold nor matter for σB).
    """
    d = level.derivatives
    norm = np.float32(level.sigma_px**2 / level.stride**2)  # σ² and level→frame units of ∂²
    trace = d.ixx + d.iyy
    s2 = (d.ixx * d.ixx + d.iyy * d.iyy + 2 * d.ixy * d.ixy) * (norm * norm)
    index = np.flatnonzero((trace < 0) & (s2 > 0.25 * min_structure_squared(c_grey)))
    lines = analyse_lines(_frame_units(level, index))
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
    return LevelResponse(level=level, response=response, peak_strength=peak, hints=hints)


def analyse_scales(
    image: np.ndarray,
    sigmas_px: tuple[float, ...],
    *,
    c_grey: float,
    peak_reach_px: float,
    max_level: int = MAX_LEVEL,
) -> MultiScaleAnalysis:
    """Gaussian derivatives at every scale and the multi-scale ridge response V.

    Parameters
    ----------
    image : ndarray of shape (M, N), float32
        Grey frame [grey levels].
    sigmas_px : tuple of float
        Scales [px].
    c_grey : float
        Structure constant of the ridge response [grey levels].
    peak_reach_px : float
        Half-size of the max filter of C [px] (see `analyse_level`).
    max_level : int
        Coarsest pyramid level for large scales; 0 is the full-resolution reference.

    Returns
    -------
    MultiScaleAnalysis
    """
    levels = scale_levels(image, sigmas_px, max_level=max_level)
    scales = tuple(
        analyse_level(lv, c_grey=c_grey, shape=image.shape, peak_reach_px=peak_reach_px)
        for lv in levels
    )
    response = np.zeros(image.shape, np.float32)
    for scale in scales:
        v = upsample_to_frame(scale.response, scale.level.level, image.shape)
        np.maximum(response, v, out=response)
    return MultiScaleAnalysis(tuple(float(s) for s in sigmas_px), scales, response)


def lines_at(level: ScaleLevel, rows: np.ndarray, cols: np.ndarray) -> LineAnalysis:
    """Line analysis of one scale at frame pixels (rows, cols)."""
    return analyse_lines(sample_derivatives(level, rows, cols))


def chosen_index(scales: tuple[LevelResponse, ...], rows, cols) -> np.ndarray:
    """Index of the scale with the largest ridge-peak strength per pixel, −1 if none > 0."""
    best = np.zeros(rows.size, np.float32)
    index = np.full(rows.size, -1, np.int64)
    for i, scale in enumerate(scales):
        c = sample_bilinear(scale.level, scale.peak_strength, rows, cols)
        better = c > best
        best[better] = c[better]
        index[better] = i
    return index


def choose_scales(
    scales: tuple[LevelResponse, ...], rows: np.ndarray, cols: np.ndarray, index: np.ndarray
) -> ScaleChoice:
    """Per pixel, the line analysis at the scale σB maximising C(σ) = σ²|λ1| at its ridge.

    `index` is that scale per pixel (`chosen_index`, or `choose_in_band`), −1 for none.

    Notes
    -----
    Paper eq. (7): the σ²-normalisation compensates the decay of λ1 with σ, so the maximum
    of C picks the scale that matches the local stripe width. C is compared at the ridge
    (max-filtered across the stripe), so every pixel of one cross-section chooses the same
    scale: choosing per pixel would let the flanks pick another scale than the centre, and
    two scales' centres of a curved stripe differ by (σ2² − σ1²)/(2R), enough to double or
    drop centres.
    """
    fields = [np.zeros(rows.size, np.float32) for _ in range(6)]
    for i, scale in enumerate(scales):
        at = np.flatnonzero(index == i)
        if not at.size:
            continue
        lines = lines_at(scale.level, rows[at], cols[at])
        strength = np.float32(scale.level.sigma_px**2) * -np.minimum(lines.lambda1, 0)
        values = (strength, lines.lambda1, lines.lambda2, lines.nx, lines.ny, lines.offset_px)
        for out, value in zip(fields, values, strict=True):
            out[at] = value
    strength, lambda1, lambda2, nx, ny, offset = fields
    chosen = LineAnalysis(
        sigma_px=float("nan"), lambda1=lambda1, lambda2=lambda2, nx=nx, ny=ny, offset_px=offset
    )
    return ScaleChoice(scale_index=index, strength=strength, lines=chosen)


@kernel
def _choose_in_band(mask, hints, peaks, strides, sigmas, blocks):
    height, width = mask.shape
    levels = len(peaks)
    sigma_map = np.zeros((height, width), np.float32)
    most = int(blocks.sum()) * BLOCK_PX * BLOCK_PX
    rows = np.empty(most, np.int64)
    cols = np.empty(most, np.int64)
    index = np.empty(most, np.int64)
    count = 0
    runs = block_runs(blocks)
    starts = run_starts(runs, blocks.shape[0])
    # The bilinear taps of `bilinear_at`, once per column and per row instead of per pixel.
    u0, u1, fu = column_taps(peaks, strides, width)
    v0 = np.zeros(levels, np.int64)
    v1 = np.zeros(levels, np.int64)
    fv = np.zeros(levels)
    for r in range(height):
        br = r // BLOCK_PX
        if starts[br] == starts[br + 1]:
            continue
        for i in range(levels):
            if strides[i] > 1:
                v0[i], v1[i], fv[i] = linear_tap(r, strides[i], peaks[i].shape[0])
        for k in range(starts[br], starts[br + 1]):
            for c in range(runs[k, 1] * BLOCK_PX, min(runs[k, 2] * BLOCK_PX, width)):
                if not mask[r, c]:
                    continue
                best = np.float32(0.0)
                chosen = -1
                hinted = False
                for i in range(levels):
                    if strides[i] == 1:
                        value = peaks[i][r, c]
                    else:
                        value = np.float32(
                            blend(peaks[i], v0[i], v1[i], fv[i], u0[i, c], u1[i, c], fu[i, c])
                        )
                    if value > best:
                        best = value
                        chosen = i
                    hinted = hinted or hints[i][r, c]
                if chosen >= 0:
                    sigma_map[r, c] = sigmas[chosen]
                if hinted:
                    rows[count], cols[count], index[count] = r, c, chosen
                    count += 1
    return sigma_map, rows[:count].copy(), cols[:count].copy(), index[:count].copy()


def choose_in_band(
    scales: tuple[LevelResponse, ...],
    sigmas_px: tuple[float, ...],
    mask: np.ndarray,
    blocks: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """σB over the mask, and the centre candidates (mask pixels some scale hints at).

    Returns
    -------
    sigma_map : ndarray of shape (M, N), float32
        σB per mask pixel (as `scale_map`), 0 elsewhere.
    rows, cols, index : ndarray of shape (K,), int64
        Candidates in raster order and their σB index (as `chosen_index`).
    """
    return _choose_in_band(
        mask,
        tuple(scale.hints for scale in scales),
        tuple(scale.peak_strength for scale in scales),
        tuple(scale.level.stride for scale in scales),
        np.asarray(sigmas_px, np.float32),
        blocks,
    )


def scale_map(
    scales: tuple[LevelResponse, ...],
    sigmas_px: tuple[float, ...],
    rows: np.ndarray,
    cols: np.ndarray,
    shape: tuple[int, int],
) -> np.ndarray:
    """σB at the mask pixels (rows, cols), as `choose_scales` picks it; 0 elsewhere.

    Returns
    -------
    ndarray of shape `shape`, float32
    """
    index = chosen_index(scales, rows, cols)
    sigmas = np.asarray((0.0, *sigmas_px), np.float32)
    out = np.zeros(shape, np.float32)
    out[rows, cols] = sigmas[index + 1]
    return out
