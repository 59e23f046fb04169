"""The multi-scale adaptive analysis: scales from the width range, V = max over scales, σB."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pipeline.ridges import ridge_response
from pipeline.steger import ScaleAnalysis, analyse_scale


@dataclass(frozen=True, slots=True, eq=False)
class MultiScaleAnalysis:
    """Per-pixel results over the scales σ1..σS; arrays (M, N).

    `response` is V(σA) = max over scales of the ridge response (float32, [0, 1)).
    `scale_index` (int8) is the index of σB = argmax σ²|λ1| among scales with λ1 < 0, −1 where
    no scale sees a bright line. `strength` = σB²|λ1(σB)| [grey levels]; `lambda1`, `nx`, `ny`,
    `offset_px` are taken at σB (float32). `gradients` holds |∇I| per scale (for widths), and
    `fixed` the full analysis of one scale when asked for (to reuse it for fixed-σ Steger).
    """

    sigmas_px: tuple[float, ...]
    response: np.ndarray
    scale_index: np.ndarray
    strength: np.ndarray
    lambda1: np.ndarray
    nx: np.ndarray
    ny: np.ndarray
    offset_px: np.ndarray
    gradients: tuple[np.ndarray, ...]
    fixed: ScaleAnalysis | None


def stripe_scales(width_min_px: float, width_max_px: float) -> tuple[float, float, float]:
    """The three scales σ1 = wmin/√3, σ2 = (wmin+wmax)/(2√3), σ3 = wmax/√3 [px] (paper §3.2)."""
    root3 = math.sqrt(3.0)
    return (
        width_min_px / root3,
        (width_min_px + width_max_px) / (2 * root3),
        width_max_px / root3,
    )


def analyse_scales(
    image: np.ndarray,
    sigmas_px: tuple[float, ...],
    *,
    c_grey: float,
    fixed_sigma_px: float | None = None,
) -> MultiScaleAnalysis:
    """Run the line analysis at every scale and keep V's maximum and the best scale σB.

    Parameters
    ----------
    image : ndarray of shape (M, N), float32
        Grey frame [grey levels].
    sigmas_px : tuple of float
        Scales [px], ascending.
    c_grey : float
        Structure constant of the ridge response [grey levels].
    fixed_sigma_px : float, optional
        When equal to one of `sigmas_px`, that scale's full `ScaleAnalysis` is kept.

    Returns
    -------
    MultiScaleAnalysis

    Notes
    -----
    Scale-normalised strength C(σ) = σ²|λ1| (paper eq. (7)); σB = argmax C over the scales
    where λ1 < 0. Both V and C use the same fixed σ² normalisation.
    """
    shape = image.shape
    response = np.zeros(shape, np.float32)
    best = np.zeros(shape, np.float32)
    index = np.full(shape, -1, np.int8)
    lambda1, nx, ny, offset = (np.zeros(shape, np.float32) for _ in range(4))
    gradients = []
    fixed = None
    for i, sigma in enumerate(sigmas_px):
        scale = analyse_scale(image, sigma)
        np.maximum(
            response,
            ridge_response(scale.lambda1, scale.lambda2, sigma, c_grey=c_grey),
            out=response,
        )
        strength = np.float32(sigma**2) * -np.minimum(scale.lambda1, 0)
        better = strength > best
        best[better] = strength[better]
        index[better] = i
        for out, value in (
            (lambda1, scale.lambda1),
            (nx, scale.nx),
            (ny, scale.ny),
            (offset, scale.offset_px),
        ):
            out[better] = value[better]
        gradients.append(scale.gradient)
        if fixed_sigma_px is not None and sigma == fixed_sigma_px:
            fixed = scale
    return MultiScaleAnalysis(
        sigmas_px=tuple(float(s) for s in sigmas_px),
        response=response,
        scale_index=index,
        strength=best,
        lambda1=lambda1,
        nx=nx,
        ny=ny,
        offset_px=offset,
        gradients=tuple(gradients),
        fixed=fixed,
    )
