"""Vectorised eigen-analysis of the 2×2 image Hessian: eigenvalues and the stripe normal."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pipeline.jit import kernel


@dataclass(frozen=True, slots=True, eq=False)
class HessianEigen:
    """Eigen-decomposition of the Hessian [[Ixx, Ixy], [Ixy, Iyy]] per pixel.

    `lambda1` is the eigenvalue of larger magnitude (|λ1| ≥ |λ2|), `lambda2` the other, in
    grey levels per px². (`nx`, `ny`) is the unit eigenvector of λ1: across a bright stripe it
    is the stripe normal (λ1 < 0). All arrays share the input's shape and dtype.
    """

    lambda1: np.ndarray
    lambda2: np.ndarray
    nx: np.ndarray
    ny: np.ndarray


TINY_NORMAL = 1e-18
"""Length of the eigenvector (not yet normalised) below which `unit_normal` scales it by
`np.hypot`: its squares lie near the subnormals (float32 from 1e-19)."""


@kernel
def eigen2_parts(ixx: float, ixy: float, iyy: float) -> tuple[float, float, float, float, float]:
    """λ1, λ2 (|λ1| ≥ |λ2|), the eigenvector (vx, vy) of λ1 not yet normalised, and its
    length √(vx² + vy²): `eigen2` before `unit_normal`, by selects rather than branches,
    so that a loop over it vectorises (`band_analysis._analyse_blocks`)."""
    mean = 0.5 * (ixx + iyy)
    half_diff = 0.5 * (ixx - iyy)
    root = np.sqrt(half_diff * half_diff + ixy * ixy)
    signed_root = -root if mean < 0 else root
    lambda1 = mean + signed_root
    lambda2 = mean - signed_root
    ax, ay = ixy, lambda1 - ixx
    bx, by = lambda1 - iyy, ixy
    longer_a = ax * ax + ay * ay >= bx * bx + by * by
    vx = ax if longer_a else bx
    vy = ay if longer_a else by
    return lambda1, lambda2, vx, vy, np.sqrt(vx * vx + vy * vy)  # no overflow: grey levels


@kernel
def unit_normal(vx: float, vy: float, norm: float) -> tuple[float, float]:
    """(vx, vy) / `norm` (its length, `eigen2_parts`); (1, 0) where it is 0."""
    if norm < TINY_NORMAL:
        norm = np.hypot(vx, vy)
    if norm == 0:
        return 1.0, 0.0
    return vx / norm, vy / norm


@kernel
def eigen2(ixx: float, ixy: float, iyy: float) -> tuple[float, float, float, float]:
    """λ1, λ2 (|λ1| ≥ |λ2|) and the unit eigenvector (nx, ny) of λ1 of one 2×2 Hessian.

    λ = m ± r with m = (Ixx + Iyy)/2 and r = √(((Ixx − Iyy)/2)² + Ixy²); the larger magnitude
    is m + sign(m)·r. The eigenvector of λ1 is (Ixy, λ1 − Ixx) or (λ1 − Iyy, Ixy); the longer
    of the two is used, which is the numerically stable choice. Where the Hessian is a multiple
    of the identity the normal is undefined and (1, 0) is returned.
    """
    lambda1, lambda2, vx, vy, norm = eigen2_parts(ixx, ixy, iyy)
    nx, ny = unit_normal(vx, vy, norm)
    return lambda1, lambda2, nx, ny


@kernel
def _eigen_all(ixx, ixy, iyy, lambda1, lambda2, nx, ny) -> None:
    """`eigen2` of every entry: eigenvalues and normals in a loop of selects (it
    vectorises), then `unit_normal` where an eigenvector's length is below TINY_NORMAL."""
    length = np.empty(ixx.size)
    for k in range(ixx.size):
        lambda1[k], lambda2[k], vx, vy, length[k] = eigen2_parts(ixx[k], ixy[k], iyy[k])
        nx[k], ny[k] = vx / length[k], vy / length[k]
    for k in range(ixx.size):
        if length[k] < TINY_NORMAL:
            vx, vy, norm = eigen2_parts(ixx[k], ixy[k], iyy[k])[2:]
            nx[k], ny[k] = unit_normal(vx, vy, norm)


def hessian_eigen(ixx: np.ndarray, ixy: np.ndarray, iyy: np.ndarray) -> HessianEigen:
    """Eigenvalues (|λ1| ≥ |λ2|) and the unit eigenvector of λ1 of the 2×2 Hessian.

    Parameters
    ----------
    ixx, ixy, iyy : ndarray, float32 or float64, all of one shape
        Second Gaussian derivatives [grey levels/px²] (x = column, y = row).

    Returns
    -------
    HessianEigen
        λ1, λ2 and the normal (nx, ny), same shape and dtype as the inputs (see `eigen2`).
    """
    shape, dtype = np.shape(ixx), np.result_type(ixx)
    flat = [np.ascontiguousarray(a, dtype).ravel() for a in (ixx, ixy, iyy)]
    out = [np.empty(flat[0].size, dtype) for _ in range(4)]
    _eigen_all(*flat, *out)
    lambda1, lambda2, nx, ny = (a.reshape(shape) for a in out)
    return HessianEigen(lambda1=lambda1, lambda2=lambda2, nx=nx, ny=ny)
