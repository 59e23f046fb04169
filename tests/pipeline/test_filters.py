"""Gaussian derivative kernels, the Hessian eigen-analysis and the pyramid scale space."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from pipeline.extraction.band_analysis import analyse_fixed_scale
from pipeline.extraction.band_filters import band_derivatives
from pipeline.extraction.blocks import all_blocks
from pipeline.extraction.fast_exp import EXP_RELATIVE_ERROR, fast_exp
from pipeline.extraction.gaussian import MIN_SIGMA_PX, gaussian_kernels
from pipeline.extraction.hessian import hessian_eigen
from pipeline.extraction.ridges import RIDGE_THRESHOLD, ridge_estimate, ridge_value
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


def test_fast_exp_is_within_its_error_bound() -> None:
    q = np.concatenate([np.linspace(-708.0, 0.0, 200_001), -np.geomspace(1e-12, 40.0, 20_001)])
    fast = np.array([fast_exp(v) for v in q])
    np.testing.assert_array_less(np.abs(fast / np.exp(q) - 1), EXP_RELATIVE_ERROR)


def test_ridge_estimate_is_on_the_same_side_of_the_threshold_as_v() -> None:
    """The frame grid's V (`ridge_estimate`) decides V > RIDGE_THRESHOLD as `ridge_value`
    does, stored as float32, also for eigenvalues placed within 10⁻⁹ of the threshold."""
    rng = np.random.default_rng(3)
    c_grey = 2.55
    lambda1 = -rng.uniform(0.5, 60.0, 4000)
    # λ2/λ1 where V is the threshold or where float32 starts to round above it (0.5 + 2⁻²⁵),
    # for each λ1 (when reachable), then nudged around it.
    structure = 1 - np.exp(-(lambda1**2) / (2 * c_grey**2))
    target = RIDGE_THRESHOLD + rng.choice([0.0, 2.0**-25], lambda1.size)
    edge = np.sqrt(np.maximum(-0.5 * np.log(target / structure), 0.0))
    nudge = rng.choice([-1e-6, -1e-8, -1e-9, 0.0, 1e-9, 1e-8, 1e-6], lambda1.size)
    near = rng.random(lambda1.size) < 0.8
    ratio = np.clip(np.where(near, edge + nudge, rng.uniform(-1, 1, lambda1.size)), -1, 1)
    lambda2 = ratio * lambda1
    exact = np.array([ridge_value(a, b, c_grey) for a, b in zip(lambda1, lambda2, strict=True)])
    estimate = np.array(
        [ridge_estimate(a, b, c_grey) for a, b in zip(lambda1, lambda2, strict=True)]
    )
    np.testing.assert_allclose(estimate, exact, rtol=0, atol=1.5e-8)
    np.testing.assert_array_equal(
        estimate.astype(np.float32) > RIDGE_THRESHOLD, exact.astype(np.float32) > RIDGE_THRESHOLD
    )
    assert np.abs(exact - RIDGE_THRESHOLD - 2.0**-25).min() < 1e-9  # reaches the rounding
