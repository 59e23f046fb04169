"""Gaussian derivative kernels, the Hessian eigen-analysis and the pyramid scale space."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from pipeline.extraction.band_analysis import analyse_fixed_scale
from pipeline.extraction.band_filters import band_derivatives
from pipeline.extraction.blocks import all_blocks
from pipeline.extraction.gaussian import MIN_SIGMA_PX, gaussian_kernels
from pipeline.extraction.hessian import hessian_eigen
from pipeline.extraction.scalespace import interpolate_cubic, level_for, sample_derivatives


@pytest.mark.parametrize("sigma_px", [0.8, 1.0, 2.887, 7.5, 12.1])
def test_kernels_have_exact_polynomial_moments(sigma_px: float) -> None:
    k = gaussian_kernels(sigma_px)
    offsets = np.arange(-k.radius_px, k.radius_px + 1)
    assert k.g0.sum() == pytest.approx(1)
    assert k.g1.sum() == pytest.approx(0, abs=1e-12)
    assert np.sum(offsets * k.g1) == pytest.approx(-1)
    assert k.g2.sum() == pytest.approx(0, abs=1e-12)
    assert np.sum(offsets**2 * k.g2) == pytest.approx(2)


@pytest.mark.parametrize("sigma_px", [1.5, 4.0])
def test_derivatives_are_exact_on_quadratics(sigma_px: float) -> None:
    rows, cols = np.mgrid[0:70, 0:90].astype(np.float32)
    image = (3 * cols + 0.5 * rows + 0.02 * cols**2 + 0.01 * cols * rows - 0.03 * rows**2).astype(
        np.float32
    )
    blocks = all_blocks(image.shape)
    d = band_derivatives(image, sigma_px, blocks, ~blocks)
    r, c = 35, 45
    assert d.ix.dtype == np.float32
    assert d.ix[r, c] == pytest.approx(3 + 0.04 * c + 0.01 * r, rel=1e-4)
    assert d.iy[r, c] == pytest.approx(0.5 + 0.01 * c - 0.06 * r, rel=1e-4)
    assert d.ixx[r, c] == pytest.approx(0.04, rel=1e-4)
    assert d.ixy[r, c] == pytest.approx(0.01, rel=1e-4)
    assert d.iyy[r, c] == pytest.approx(-0.06, rel=1e-4)


@pytest.mark.parametrize("sigma_px", [0.5, float("nan"), -1.0])
def test_bad_sigma_is_refused(sigma_px: float) -> None:
    with pytest.raises(ValueError, match=f"sigma_px must be a finite number ≥ {MIN_SIGMA_PX}"):
        gaussian_kernels(sigma_px)


@settings(max_examples=50, deadline=None)
@given(
    st.lists(st.floats(-100, 100, allow_nan=False, allow_subnormal=False), min_size=3, max_size=3)
)
@example([1.5661657864936887e-78, 2.068066724230026e-162, 1.5661657864936887e-78])  # underflow
def test_eigen_analysis_matches_numpy(values: list[float]) -> None:
    ixx, ixy, iyy = (np.array([v]) for v in values)
    eigen = hessian_eigen(ixx, ixy, iyy)
    reference = np.linalg.eigvalsh(np.array([[values[0], values[1]], [values[1], values[2]]]))
    # Equal magnitudes (λ = ±r) leave the order open: check the pair and |λ1| ≥ |λ2|.
    pair = sorted([float(eigen.lambda1[0]), float(eigen.lambda2[0])])
    assert pair == pytest.approx(sorted(reference), abs=1e-9)
    assert abs(eigen.lambda1[0]) >= abs(eigen.lambda2[0]) - 1e-9
    assert np.hypot(eigen.nx[0], eigen.ny[0]) == pytest.approx(1)
    hessian = np.array([[values[0], values[1]], [values[1], values[2]]])
    n = np.array([eigen.nx[0], eigen.ny[0]])
    np.testing.assert_allclose(
        hessian @ n, eigen.lambda1[0] * n, atol=1e-6 * (1 + np.abs(values).max())
    )


def test_large_scales_go_to_coarser_levels() -> None:
    assert level_for(2.887, 2) == 0
    assert level_for(7.5, 2) == 1
    assert level_for(12.1, 2) == 2
    assert level_for(12.1, 0) == 0


def test_cubic_interpolation_reproduces_quadratics() -> None:
    rows, cols = np.mgrid[0:20, 0:20].astype(np.float32)
    field = (1 + 0.5 * cols - 0.25 * rows + 0.03 * cols**2 + 0.02 * cols * rows).astype(np.float32)
    u = np.array([5.25, 7.75, 10.125])
    v = np.array([6.5, 9.375, 11.0])
    expected = 1 + 0.5 * u - 0.25 * v + 0.03 * u**2 + 0.02 * u * v
    np.testing.assert_allclose(interpolate_cubic(field, u, v), expected, rtol=1e-5)


def test_pyramid_derivatives_match_full_resolution() -> None:
    rows, cols = np.mgrid[0:160, 0:200].astype(np.float64)
    distance = rows - 80 - 0.002 * (cols - 100) ** 2
    image = (12 + 170 * np.exp(-8 * distance**2 / 9**2)).astype(np.float32)
    inside_r, inside_c = np.mgrid[50:110, 50:150]
    r, c = inside_r.ravel(), inside_c.ravel()
    for sigma in (7.5, 12.1):
        coarse = analyse_fixed_scale(image, sigma, c_grey=2.55).level
        assert coarse.level > 0
        fast = sample_derivatives(coarse, r, c)
        reference = analyse_fixed_scale(image, sigma, c_grey=2.55, max_level=0).level.derivatives
        for name in ("ix", "iy", "ixx", "ixy", "iyy"):
            full = getattr(reference, name)
            error = np.abs(getattr(fast, name) - full[r, c]).max()
            assert error < 0.01 * np.abs(full).max(), (sigma, name, error)
