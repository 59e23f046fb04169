"""The multi-scale adaptive analysis: scales from the width range, V = max over scales, σB.

Equations and constants: docs/extraction.md §1 (scales), §3 (V) and §4 (σB).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pipeline.extraction.blocks import BLOCK_PX, block_runs, run_starts
from pipeline.extraction.scalespace import (
    ScaleLevel,
    blend,
    column_taps,
    linear_tap,
    sample_derivatives,
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
    matter; on the frame grid, read only against RIDGE_THRESHOLD, V to within 1.5·10⁻⁸ on
    the same side of it (`ridges.ridge_estimate`); `peak_strength` (float32, level grid)
    is C = σ²|λ1| [grey levels] max-filtered across the stripe, the value at the ridge
    (valid on the blocks holding the mask, where it is read); `hints` (bool, frame grid)
    marks frame pixels that may hold a centre at this scale.
    """

    level: ScaleLevel
    response: np.ndarray
    peak_strength: np.ndarray
    hints: np.ndarray


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


def lines_at(level: ScaleLevel, rows: np.ndarray, cols: np.ndarray) -> LineAnalysis:
    """Line analysis of one scale at frame pixels (rows, cols)."""
    return analyse_lines(sample_derivatives(level, rows, cols))


def choose_scales(
    scales: tuple[LevelResponse, ...], rows: np.ndarray, cols: np.ndarray, index: np.ndarray
) -> ScaleChoice:
    """Per pixel, the line analysis at the scale σB maximising C(σ) = σ²|λ1| at its ridge.

    `index` is that scale per pixel (`choose_in_band`), −1 for none.

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
        σB per mask pixel, 0 elsewhere and where no scale has C > 0.
    rows, cols, index : ndarray of shape (K,), int64
        Candidates in raster order and the index of their σB (the scale with the largest
        ridge-peak strength C, bilinear on coarser levels), −1 if none has C > 0.
    """
    return _choose_in_band(
        mask,
        tuple(scale.hints for scale in scales),
        tuple(scale.peak_strength for scale in scales),
        tuple(scale.level.stride for scale in scales),
        np.asarray(sigmas_px, np.float32),
        blocks,
    )
