"""Steger's sub-pixel line centre: second-order Taylor step along the normal, ±0.5 px test."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pipeline.gaussian import GaussianDerivatives, gaussian_derivatives
from pipeline.hessian import hessian_eigen

MAX_OFFSET_PX = 0.5
"""A centre is kept only inside its own pixel: |t·nx| ≤ 0.5 and |t·ny| ≤ 0.5 (Steger eq. (10))."""


@dataclass(frozen=True, slots=True, eq=False)
class ScaleAnalysis:
    """Per-pixel line analysis of one image at one Gaussian scale; float32 arrays (M, N).

    `lambda1`, `lambda2` (|λ1| ≥ |λ2|) in grey levels/px²; (`nx`, `ny`) the unit normal;
    `offset_px` the signed Taylor step t [px] along the normal from the pixel centre to the
    line centre; `gradient` the gradient magnitude |∇I| [grey levels/px] (for widths).
    """

    sigma_px: float
    lambda1: np.ndarray
    lambda2: np.ndarray
    nx: np.ndarray
    ny: np.ndarray
    offset_px: np.ndarray
    gradient: np.ndarray


def taylor_offset(derivatives: GaussianDerivatives, lambda1: np.ndarray, nx, ny) -> np.ndarray:
    """Signed sub-pixel offset t [px] of the line centre along the normal (nx, ny).

    Notes
    -----
    Steger eq. (8): t = −(nx·Ix + ny·Iy) / (nx²·Ixx + 2·nx·ny·Ixy + ny²·Iyy). Because
    (nx, ny) is the unit eigenvector of λ1, the denominator equals λ1. Where λ1 = 0 there is
    no extremum and t = +inf (rejected by the ±0.5 px test).
    """
    numerator = -(nx * derivatives.ix + ny * derivatives.iy)
    with np.errstate(divide="ignore", invalid="ignore"):
        offset = numerator / lambda1
    return np.where(lambda1 == 0, np.inf, offset).astype(lambda1.dtype, copy=False)


def analyse_scale(image: np.ndarray, sigma_px: float) -> ScaleAnalysis:
    """Hessian eigen-analysis and Taylor step of a float32 image at one scale.

    Parameters
    ----------
    image : ndarray of shape (M, N), float32
        Grey frame [grey levels].
    sigma_px : float
        Gaussian scale [px].

    Returns
    -------
    ScaleAnalysis
        Per-pixel eigenvalues, normal, Taylor offset and gradient magnitude.
    """
    derivatives = gaussian_derivatives(image, sigma_px)
    eigen = hessian_eigen(derivatives.ixx, derivatives.ixy, derivatives.iyy)
    offset = taylor_offset(derivatives, eigen.lambda1, eigen.nx, eigen.ny)
    return ScaleAnalysis(
        sigma_px=float(sigma_px),
        lambda1=eigen.lambda1,
        lambda2=eigen.lambda2,
        nx=eigen.nx,
        ny=eigen.ny,
        offset_px=offset,
        gradient=np.hypot(derivatives.ix, derivatives.iy),
    )


def centre_pixels(lambda1: np.ndarray, nx, ny, offset_px: np.ndarray) -> np.ndarray:
    """Boolean map of pixels holding a bright-line centre.

    Notes
    -----
    A bright line has λ1 < 0; the centre lies in the pixel when |t·nx| ≤ 0.5 and
    |t·ny| ≤ 0.5 (Steger eq. (10)), so each centre is found by exactly one pixel.
    """
    return (
        (lambda1 < 0)
        & (np.abs(offset_px * nx) <= MAX_OFFSET_PX)
        & (np.abs(offset_px * ny) <= MAX_OFFSET_PX)
    )
