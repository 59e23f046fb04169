"""Frangi-like multi-scale ridge response of bright stripes (σ²-normalised, fixed constants)."""

from __future__ import annotations

import math

import numpy as np

RIDGE_BETA = 0.5
"""β of the blob term exp(−RA²/2β²): a round spot (RA ≈ 1) keeps exp(−2) ≈ 0.14 of its
response, a line (RA ≈ 0) all of it."""

RIDGE_C_FULL_SCALE = 0.01
"""c of the structure term 1 − exp(−S²/2c²), as a fraction of the frame's full scale
(255 for 8-bit, 65535 for 16-bit). S is σ²-normalised, so c is in grey levels: 2.55 for an
8-bit frame. A 30-grey-level, 5 px wide stripe reaches S ≈ 10 (σ = 2.9 px), read noise of
σ 10 grey levels about 0.85 (one standard deviation)."""

RIDGE_THRESHOLD = 0.5
"""Threshold on the multi-scale ridge response V ∈ [0, 1): half the saturated response."""


def ridge_response(lambda1: np.ndarray, lambda2: np.ndarray, *, c_grey: float) -> np.ndarray:
    """Frangi-like bright-ridge response V ∈ [0, 1) from σ²-normalised eigenvalues.

    Parameters
    ----------
    lambda1, lambda2 : ndarray, float32
        σ²-normalised Hessian eigenvalues σ²λ with |λ1| ≥ |λ2| [grey levels].
    c_grey : float
        Structure constant c [grey levels], > 0.

    Returns
    -------
    ndarray, float32
        V, 0 where λ1 ≥ 0 (dark lines and background).

    Notes
    -----
    V = exp(−RA²/2β²)·(1 − exp(−S²/2c²)), RA = λ2/λ1, S = √(λ1² + λ2²) (paper eqs. (4)–(6),
    with the fixed σ²-normalisation that makes scales comparable).
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(lambda1 < 0, lambda2 / lambda1, 0).astype(np.float32, copy=False)
    s2 = lambda1 * lambda1 + lambda2 * lambda2
    blob = np.exp(ratio * ratio * np.float32(-1 / (2 * RIDGE_BETA**2)))
    structure = 1 - np.exp(s2 * np.float32(-1 / (2 * c_grey**2)))
    return np.where(lambda1 < 0, blob * structure, 0).astype(np.float32, copy=False)


def min_structure_squared(c_grey: float) -> float:
    """Least S² [grey levels²] at which V can exceed RIDGE_THRESHOLD: −2c²·ln(1 − threshold)."""
    return -2 * c_grey**2 * math.log(1 - RIDGE_THRESHOLD)
