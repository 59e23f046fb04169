"""Frangi-like multi-scale ridge response of bright stripes (σ²-normalised, fixed constants)."""

from __future__ import annotations

import math

import numpy as np

from pipeline.extraction.fast_exp import fast_exp
from pipeline.jit import kernel

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


STRUCTURE_SATURATED = 40.0
"""S²/2c² beyond which the structure term 1 − exp(−S²/2c²) is exactly 1 in float64: from
37.43 on, exp(−S²/2c²) ≤ 2⁻⁵⁴ and 1 minus it rounds to 1 (at 40 it is 4.2·10⁻¹⁸, a margin
of 13× over any error of the exp). A stripe's pixels lie far beyond it (S²/2c² ≈ 250 for
a peak contrast of 150 grey levels), so their V costs one exp, not two, with the same bits."""


THRESHOLD_MARGIN = 1e-6
"""`ridge_estimate` is within 2·EXP_RELATIVE_ERROR (1.5·10⁻⁸) of V; where it lies within
this of RIDGE_THRESHOLD, V itself is computed (a margin of 67× the error, and of 30× the
half ulp of float32 at 0.5, where V is stored)."""


@kernel
def _exponents(lambda1: float, lambda2: float, c_grey: float) -> tuple[float, float]:
    """The exponents of V's blob term, −RA²/2β², and structure term, −S²/2c²."""
    ratio = lambda2 / lambda1
    blob_exponent = ratio * ratio * (-1 / (2 * RIDGE_BETA**2))
    return blob_exponent, (lambda1 * lambda1 + lambda2 * lambda2) * (-1 / (2 * c_grey**2))


@kernel
def ridge_value(lambda1: float, lambda2: float, c_grey: float) -> float:
    """V of one pixel from its σ²-normalised eigenvalues (see `ridge_response`)."""
    if not lambda1 < 0:
        return 0.0
    blob_exponent, exponent = _exponents(lambda1, lambda2, c_grey)
    blob = np.exp(blob_exponent)
    if exponent < -STRUCTURE_SATURATED:
        return blob  # × a structure term of exactly 1
    return blob * (1 - np.exp(exponent))


@kernel
def fast_ridge(lambda1: float, lambda2: float, c_grey: float) -> float:
    """`ridge_value` with its two exp by `fast_exp`, by selects rather than branches, so
    that a loop over it vectorises: within 2·EXP_RELATIVE_ERROR of V."""
    blob_exponent, exponent = _exponents(lambda1, lambda2, c_grey)
    blob = fast_exp(blob_exponent)
    # Both exp always: with the second inside the select's arm the compiler keeps a branch,
    # and the loop stays scalar (9.5 against 1.1 ms for 851k values).
    structure = 1 - fast_exp(exponent)
    value = blob if exponent < -STRUCTURE_SATURATED else blob * structure
    return value if lambda1 < 0 else 0.0


@kernel
def near_threshold(value: float) -> bool:
    """Whether `fast_ridge`'s V lies within THRESHOLD_MARGIN of RIDGE_THRESHOLD, where
    `ridge_value` decides its side."""
    return abs(value - RIDGE_THRESHOLD) < THRESHOLD_MARGIN


@kernel
def ridge_estimate(lambda1: float, lambda2: float, c_grey: float) -> float:
    """V of one pixel to within 1.5·10⁻⁸, on the same side of RIDGE_THRESHOLD as
    `ridge_value` bit for bit (in float64 and once stored as float32), for fields that are
    only ever compared with the threshold.

    Its two exp are `fast_exp` (`fast_ridge`: the blob term's exponent lies in [−2, 0] as
    |λ2| ≤ |λ1|, the structure term's in [−STRUCTURE_SATURATED, 0]), each within
    EXP_RELATIVE_ERROR; within THRESHOLD_MARGIN of the threshold `ridge_value` decides. On
    a lit frame's grid of σ1 (851k candidates, 1.97 exp each) about 15 % of the V/C/hints
    kernel.
    """
    value = fast_ridge(lambda1, lambda2, c_grey)
    if near_threshold(value):
        return ridge_value(lambda1, lambda2, c_grey)
    return value


@kernel
def _ridge_all(lambda1, lambda2, c_grey, out) -> None:
    for k in range(lambda1.size):
        out[k] = ridge_value(lambda1[k], lambda2[k], c_grey)


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
    shape = np.shape(lambda1)
    out = np.empty(shape, np.float32)
    _ridge_all(
        np.ascontiguousarray(lambda1).ravel(),
        np.ascontiguousarray(lambda2).ravel(),
        float(c_grey),
        out.ravel(),
    )
    return out


def min_structure_squared(c_grey: float) -> float:
    """Least S² [grey levels²] at which V can exceed RIDGE_THRESHOLD: −2c²·ln(1 − threshold)."""
    return -2 * c_grey**2 * math.log(1 - RIDGE_THRESHOLD)
