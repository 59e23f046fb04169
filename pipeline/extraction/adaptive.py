"""The multi-scale adaptive analysis: scales from the width range, V = max over scales, σB."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pipeline.extraction.components import band_pixels
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
    matter; `peak_strength` (float32, level grid) is C = σ²|λ1| [grey levels] max-filtered
    across the stripe, the value at the ridge; `hints` (bool, frame grid) marks frame pixels
    that may hold a centre at this scale.
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
def _best_scale(peak, hints, stride, i, rows, cols, best, chosen, hinted) -> None:
    """Fold scale i into the running best ridge-peak C, its index and the hints at the
    pixels (rows, cols); C bilinear (`blend`) on a coarser level."""
    width = hints.shape[1]
    if stride > 1:
        u0, u1, fu = column_taps((peak,), (stride,), width)
        last_row = -1
        v0, v1, fv = 0, 0, 0.0
    for k in range(rows.size):
        r, c = rows[k], cols[k]
        if stride == 1:
            value = peak[r, c]
        else:
            if r != last_row:
                v0, v1, fv = linear_tap(r, stride, peak.shape[0])
                last_row = r
            value = np.float32(blend(peak, v0, v1, fv, u0[0, c], u1[0, c], fu[0, c]))
        if value > best[k]:
            best[k] = value
            chosen[k] = i
        hinted[k] |= hints[r, c]


@kernel
def _chosen_pixels(rows, cols, chosen, hinted, sigmas, sigma_map):
    """σB into the σ map at the pixels with a chosen scale; the hinted pixels' rows,
    columns and scale index."""
    for k in range(rows.size):
        if chosen[k] >= 0:
            sigma_map[rows[k], cols[k]] = sigmas[chosen[k]]
    at = np.flatnonzero(hinted)
    return rows[at], cols[at], chosen[at]


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
    rows, cols = band_pixels(mask, blocks)
    best = np.zeros(rows.size, np.float32)
    chosen = np.full(rows.size, -1, np.int64)
    hinted = np.zeros(rows.size, np.bool_)
    # Scale after scale, each pixel keeps the first scale of the largest C, as a loop over
    # the scales per pixel would.
    for i, scale in enumerate(scales):
        _best_scale(
            scale.peak_strength, scale.hints, scale.level.stride, i, rows, cols, best, chosen, hinted
        )
    sigma_map = np.zeros(mask.shape, np.float32)
    picked = _chosen_pixels(rows, cols, chosen, hinted, np.asarray(sigmas_px, np.float32), sigma_map)
    return (sigma_map, *picked)
