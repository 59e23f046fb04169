"""The matched fit along the normal (pipeline.extraction.normal_fit) on known truth."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from pipeline.extraction.normal_fit import matched_offsets

RADIUS_PX = 40.0
CENTRE_XY = (80.3, 80.6)


def _ring(width_px: float) -> np.ndarray:
    """A bright ring of 1/e² width `width_px`: its normals run through its centre."""
    rows, cols = np.mgrid[0:161, 0:161].astype(float)
    d = np.hypot(cols - CENTRE_XY[0], rows - CENTRE_XY[1]) - RADIUS_PX
    return 12 + 150 * np.exp(-8 * d**2 / width_px**2)


@pytest.mark.parametrize("width_px", [5.0, 9.0, 17.0])
def test_matched_fit_finds_a_curved_line_without_curvature_bias(width_px) -> None:
    angle = np.linspace(0, 2 * np.pi, 90, endpoint=False)
    nx, ny = np.cos(angle), np.sin(angle)
    start = RADIUS_PX + np.random.default_rng(1).uniform(-0.6, 0.6, angle.size)
    x, y = CENTRE_XY[0] + start * nx, CENTRE_XY[1] + start * ny
    s = np.full(angle.size, width_px / 4)
    offsets = matched_offsets(_ring(width_px), x, y, nx, ny, s, (1.0, 2.0))
    for t in offsets:
        error = start + t - RADIUS_PX
        # Hessian centres at σ = w/√3 would sit (w²/3)/(2R) inside: 0.10–1.2 px here. What is
        # left is the 1 px reads of the pixel grid (max 0.016 px at w 5, s 1.25 px), no bias.
        assert abs(error.mean()) < 0.003, error
        assert np.abs(error).max() < 0.025, error


def test_no_maximum_within_reach_is_nan() -> None:
    image = np.tile(np.linspace(0, 200, 60), (60, 1))  # a ramp: no maximum along x
    t = matched_offsets(
        image, np.array([30.0]), np.array([30.0]), np.ones(1), np.zeros(1), np.full(1, 2.0), (1.0,)
    )
    assert np.isnan(t).all()


def test_profiles_past_the_frame_edge_read_the_reflected_frame() -> None:
    """Normals that run off the frame read it folded (reflect border, the direct-tap path
    not taken): the same offsets as in the frame padded by reflection, where every read is
    inside."""
    rows, cols = np.mgrid[0:60, 0:70].astype(float)
    image = (12 + 150 * np.exp(-8 * (cols - 0.1 * rows - 8.2) ** 2 / 81.0)).astype(np.uint8)
    pad = 40
    padded = cv2.copyMakeBorder(image, pad, pad, pad, pad, cv2.BORDER_REFLECT)
    norm = np.hypot(1.0, 0.1)
    y = np.array([1.5, 10.0, 30.0, 58.5])  # the first and last reach past a row edge too
    x = 8.2 + 0.1 * y
    nx, ny = np.full(4, 1 / norm), np.full(4, -0.1 / norm)
    s = np.full(4, 9.0 / 4)
    at_edge = matched_offsets(image, x, y, nx, ny, s, (1.0, 2.0))
    inside = matched_offsets(padded, x + pad, y + pad, nx, ny, s, (1.0, 2.0))
    assert np.isfinite(at_edge).all()
    np.testing.assert_allclose(at_edge, inside, rtol=0, atol=1e-9)


def test_scales_fitted_side_by_side_equal_each_fitted_alone() -> None:
    """Two kernel scales share their Newton steps' passes over the samples: each offset is
    the one its scale gives alone, to the bit (noisy ring: some fits fail, some take
    more steps than others)."""
    rng = np.random.default_rng(3)
    image = _ring(9.0) + rng.normal(0, 25, (161, 161))
    angle = rng.uniform(0, 2 * np.pi, 400)
    nx, ny = np.cos(angle), np.sin(angle)
    start = RADIUS_PX + rng.uniform(-1.5, 1.5, angle.size)
    x, y = CENTRE_XY[0] + start * nx, CENTRE_XY[1] + start * ny
    s = rng.uniform(0.5, 4.0, angle.size)
    factors = (1.0, 2.0, 0.7)
    together = matched_offsets(image, x, y, nx, ny, s, factors)
    alone = [matched_offsets(image, x, y, nx, ny, s, (f,))[0] for f in factors]
    np.testing.assert_array_equal(together, np.array(alone))
    assert 0 < np.isnan(together).sum() < together.size // 2
