"""Gaussian derivative kernels at any scale: sampled and moment-normalised (the separable
filtering with them is `band_filters.band_derivatives`)."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import cv2
import numpy as np

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


@functools.lru_cache(maxsize=64)
def gaussian_kernels(sigma_px: float) -> GaussianKernels:
    """Return the sampled Gaussian and derivative kernels of scale `sigma_px`.

    Parameters
    ----------
    sigma_px : float
        Standard deviation of the Gaussian [px], ≥ MIN_SIGMA_PX.

    Returns
    -------
    GaussianKernels
        Kernels in convolution order (index 0 is offset -radius), float64, read-only:
        one object per scale, kept (a frame's scales repeat frame after frame).

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
    for kernel in (g0, g1, g2):
        kernel.flags.writeable = False
    return GaussianKernels(sigma_px=float(sigma_px), radius_px=radius_px, g0=g0, g1=g1, g2=g2)
