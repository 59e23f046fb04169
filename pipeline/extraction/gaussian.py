"""Gaussian derivative filtering at any scale: sampled, moment-normalised, separable, float32."""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from pipeline.imaging import IMAGE_FLOAT

TRUNCATE_SIGMAS = 4.0
"""Kernel half-width in σ. The Gaussian tail beyond 4σ holds 6e-5 of its mass, far below the
noise of an 8-bit frame, and the moment normalisation below removes the truncation bias."""

MIN_SIGMA_PX = 0.7
"""Smallest σ [px] at which a sampled Gaussian still approximates the continuous one."""

BORDER = cv2.BORDER_REFLECT
"""The one border mode of the pipeline: reflect with the edge pixel repeated (dcba|abcd)."""


@dataclass(frozen=True, slots=True, eq=False)
class GaussianKernels:
    """Sampled 1-D Gaussian kernels of one scale, indexed by offset -radius..radius [px].

    `g0` sums to 1. `g1` and `g2` are normalised on polynomials so that convolving with them
    returns the exact first and second derivatives of any polynomial of degree ≤ 2 (and ≤ 3
    for `g1`, by symmetry).
    """

    sigma_px: float
    radius_px: int
    g0: np.ndarray
    g1: np.ndarray
    g2: np.ndarray


@dataclass(frozen=True, slots=True, eq=False)
class GaussianDerivatives:
    """First and second Gaussian derivatives of an image at one scale, float32 (M, N).

    x is the column direction, y the row direction; values are grey levels per px (Ix, Iy)
    and grey levels per px² (Ixx, Ixy, Iyy).
    """

    sigma_px: float
    ix: np.ndarray
    iy: np.ndarray
    ixx: np.ndarray
    ixy: np.ndarray
    iyy: np.ndarray


def gaussian_kernels(sigma_px: float) -> GaussianKernels:
    """Return the sampled Gaussian and derivative kernels of scale `sigma_px`.

    Parameters
    ----------
    sigma_px : float
        Standard deviation of the Gaussian [px], ≥ MIN_SIGMA_PX.

    Returns
    -------
    GaussianKernels
        Kernels in convolution order (index 0 is offset -radius), float64.

    Raises
    ------
    ValueError
        If `sigma_px` is not finite or below MIN_SIGMA_PX.

    Notes
    -----
    Sampling and truncating G, G' and G'' breaks their moments slightly. They are restored:
    Σ g0 = 1; Σ g1 = 0 and Σ k·g1[k] = -1 (so x ↦ 1); Σ g2 = 0 and Σ k²·g2[k] = 2
    (so x²/2 ↦ 1), which makes the derivatives exact on polynomials up to degree 2.
    """
    if not math.isfinite(sigma_px) or sigma_px < MIN_SIGMA_PX:
        raise ValueError(f"sigma_px must be a finite number ≥ {MIN_SIGMA_PX}, got {sigma_px}")
    radius_px = max(1, math.ceil(TRUNCATE_SIGMAS * sigma_px))
    k = np.arange(-radius_px, radius_px + 1, dtype=np.float64)
    g = np.exp(-0.5 * (k / sigma_px) ** 2)
    g0 = g / g.sum()
    g1 = -k * g0
    g1 /= -np.sum(k * g1)
    g2 = (k**2 - sigma_px**2) * g0
    g2 -= g0 * g2.sum()
    g2 /= 0.5 * np.sum(k**2 * g2)
    return GaussianKernels(sigma_px=float(sigma_px), radius_px=radius_px, g0=g0, g1=g1, g2=g2)


def _filter_1d(image: np.ndarray, kernel: np.ndarray, axis: int) -> np.ndarray:
    """Convolve a float32 image along one axis (1 = x/columns, 0 = y/rows), reflect border."""
    # cv2 filters correlate; reversing the kernel turns the correlation into a convolution.
    taps = np.ascontiguousarray(kernel[::-1], dtype=IMAGE_FLOAT)
    one = np.ones(1, dtype=IMAGE_FLOAT)
    kernel_x, kernel_y = (taps, one) if axis == 1 else (one, taps)
    return cv2.sepFilter2D(image, cv2.CV_32F, kernel_x, kernel_y, borderType=BORDER)


def gaussian_derivatives(image: np.ndarray, sigma_px: float) -> GaussianDerivatives:
    """Compute Ix, Iy, Ixx, Ixy, Iyy of a float32 image at scale `sigma_px`.

    Parameters
    ----------
    image : ndarray of shape (M, N), float32
        Grey frame [grey levels], C-contiguous (see `pipeline.imaging.to_float_image`).
    sigma_px : float
        Gaussian scale [px].

    Returns
    -------
    GaussianDerivatives
        Five float32 (M, N) derivative images.

    Notes
    -----
    Separable: three passes along x (G, G', G'') and five along y, reflect border.
    """
    kernels = gaussian_kernels(sigma_px)
    along_x = [_filter_1d(image, kern, axis=1) for kern in (kernels.g0, kernels.g1, kernels.g2)]
    smooth_x, d1_x, d2_x = along_x
    return GaussianDerivatives(
        sigma_px=kernels.sigma_px,
        ix=_filter_1d(d1_x, kernels.g0, axis=0),
        iy=_filter_1d(smooth_x, kernels.g1, axis=0),
        ixx=_filter_1d(d2_x, kernels.g0, axis=0),
        ixy=_filter_1d(d1_x, kernels.g1, axis=0),
        iyy=_filter_1d(smooth_x, kernels.g2, axis=0),
    )
