"""Steger's sub-pixel line centre: second-order Taylor step along the normal, ±0.5 px test."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pipeline.gaussian import GaussianDerivatives
from pipeline.hessian import hessian_eigen

MAX_OFFSET_PX = 0.5
"""A centre is kept only inside its own pixel: |t·nx| ≤ 0.5 and |t·ny| ≤ 0.5 (paper eq. (10))."""


@dataclass(frozen=True, slots=True, eq=False)
class LineAnalysis:
    """Line analysis at a set of pixels at one scale; float32 arrays of one shape.

    `lambda1`, `lambda2` (|λ1| ≥ |λ2|) in grey levels/px²; (`nx`, `ny`) the unit normal;
    `offset_px` the signed Taylor step t [px] along the normal from the pixel centre to the
    line centre.
    """

    sigma_px: float
    lambda1: np.ndarray
    lambda2: np.ndarray
    nx: np.ndarray
    ny: np.ndarray
    offset_px: np.ndarray


def analyse_lines(derivatives: GaussianDerivatives) -> LineAnalysis:
    """Hessian eigen-analysis and Taylor step from Gaussian derivatives (any array shape).

    Notes
    -----
    Paper eq. (8): t = −(nx·Ix + ny·Iy) / (nx²·Ixx + 2·nx·ny·Ixy + ny²·Iyy). Because (nx, ny)
    is the unit eigenvector of λ1, the denominator equals λ1. Where λ1 = 0 there is no
    extremum and t = +inf (rejected by the ±0.5 px test).
    """
    eigen = hessian_eigen(derivatives.ixx, derivatives.ixy, derivatives.iyy)
    numerator = -(eigen.nx * derivatives.ix + eigen.ny * derivatives.iy)
    with np.errstate(divide="ignore", invalid="ignore"):
        offset = numerator / eigen.lambda1
    offset = np.where(eigen.lambda1 == 0, np.inf, offset).astype(eigen.lambda1.dtype, copy=False)
    return LineAnalysis(
        sigma_px=derivatives.sigma_px,
        lambda1=eigen.lambda1,
        lambda2=eigen.lambda2,
        nx=eigen.nx,
        ny=eigen.ny,
        offset_px=offset,
    )


def centre_pixels(lambda1: np.ndarray, nx, ny, offset_px: np.ndarray) -> np.ndarray:
    """Which pixels hold a bright-line centre.

    Notes
    -----
    A bright line has λ1 < 0; the centre lies in the pixel when |t·nx| ≤ 0.5 and
    |t·ny| ≤ 0.5 (paper eq. (10)), so each centre is found by exactly one pixel.
    """
    return (
        (lambda1 < 0)
        & (np.abs(offset_px * nx) <= MAX_OFFSET_PX)
        & (np.abs(offset_px * ny) <= MAX_OFFSET_PX)
    )
