"""The band kernels against the OpenCV/NumPy reference (tests/pipeline/opencv_reference.py):
filtering, the max filter of C, bilinear upsampling, labelling, closing, and the whole-frame
analysis they make."""

from __future__ import annotations

import functools

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pipeline import extract_centres
from pipeline.extraction.adaptive import stripe_scales
from pipeline.extraction.band_analysis import _max_filter_blocks, analyse_band
from pipeline.extraction.band_filters import band_derivatives
from pipeline.extraction.band_segmentation import _stripe_runs, runs_near_band_edge
from pipeline.extraction.blocks import BLOCK_PX, block_grid
from pipeline.extraction.centres import full_scale
from pipeline.extraction.closing import CLOSING_REACH_PX, close_runs
from pipeline.extraction.components import label_runs, paint_runs, row_runs
from pipeline.extraction.ridges import RIDGE_C_FULL_SCALE
from tests.pipeline.opencv_reference import analyse_frame, close_holes, gaussian_derivatives
from tests.pipeline.stripe_images import StripeCase, make_stripe
from tests.pipeline.test_band_path import CASES

WIDTH_MAX_PX = 21.0


@functools.cache
def _analyses(case: StripeCase):
    image = make_stripe(case).image
    sigmas = stripe_scales(5.0, WIDTH_MAX_PX)
    c_grey = RIDGE_C_FULL_SCALE * full_scale(image.dtype)
    reach = WIDTH_MAX_PX / 2
    ours = analyse_band(image, sigmas, c_grey=c_grey, peak_reach_px=reach, full_frame=True)
    reference = analyse_frame(image, sigmas, c_grey=c_grey, peak_reach_px=reach, mask=ours.mask)
    return ours, reference


@pytest.mark.parametrize("case", CASES, ids=lambda c: c.name)
def test_whole_frame_analysis_equals_the_opencv_reference(case: StripeCase) -> None:
    ours, reference = _analyses(case)
    # V > threshold of the scales upsampled (cv2.resize INTER_LINEAR) and maxed: the pixels
    # the components are labelled from.
    everywhere = np.ones(block_grid(ours.mask.shape), bool)
    runs = _stripe_runs(
        tuple(scale.response for scale in ours.scales),
        tuple(scale.level.stride for scale in ours.scales),
        everywhere,
        ours.mask.shape,
    )
    ridges = paint_runs(runs, np.ones(len(runs), bool), ours.mask.shape).view(bool)
    np.testing.assert_array_equal(ridges, reference.ridges)
    for scale, expected in zip(ours.scales, reference.scales, strict=True):
        np.testing.assert_array_equal(scale.hints, expected.hints)
        # The filters sum in another order: V to float32 rounding of the derivatives.
        np.testing.assert_allclose(scale.response, expected.response, atol=2e-4)


@pytest.mark.parametrize("case", CASES, ids=lambda c: c.name)
def test_sigma_map_equals_the_reference(case: StripeCase) -> None:
    _, reference = _analyses(case)
    centres = extract_centres(make_stripe(case).image, full_frame=True)
    np.testing.assert_array_equal(centres.sigma_map, reference.sigma_map)


def _pixels(blocks: np.ndarray, shape: tuple[int, int], dtype=bool) -> np.ndarray:
    """The frame pixels (`shape`) of a block grid's flags."""
    return np.kron(blocks, np.ones((BLOCK_PX, BLOCK_PX), dtype))[: shape[0], : shape[1]]


_max_filter_cases = given(
    seed=st.integers(0, 2**31 - 1),
    shape=st.tuples(st.integers(5, 90), st.integers(5, 90)),
    half=st.integers(1, 12),
)
"""A random field, block grid and half-width for the max filter's property tests."""


@settings(max_examples=25, deadline=None)
@_max_filter_cases
def test_max_filter_is_the_opencv_dilation_on_the_band(seed, shape, half) -> None:
    rng = np.random.default_rng(seed)
    field = (rng.random(shape) * (rng.random(shape) < 0.3)).astype(np.float32)
    grid = (-(-shape[0] // BLOCK_PX), -(-shape[1] // BLOCK_PX))
    blocks = rng.random(grid) < 0.6
    ours = _max_filter_blocks(field, blocks, half)
    reference = cv2.dilate(field, np.ones((2 * half + 1, 2 * half + 1), np.uint8))
    inside = _pixels(blocks, shape)
    np.testing.assert_array_equal(ours[inside], reference[inside])


@settings(max_examples=25, deadline=None)
@_max_filter_cases
def test_max_filter_reads_the_field_as_0_off_its_valid_blocks(seed, shape, half) -> None:
    # The frame grid's C is left unwritten on the band's ring: whatever it holds there,
    # the max filter reads 0, as from a cleared ring.
    rng = np.random.default_rng(seed)
    grid = (-(-shape[0] // BLOCK_PX), -(-shape[1] // BLOCK_PX))
    valid = rng.random(grid) < 0.6
    blocks = valid & (rng.random(grid) < 0.7)
    inside = _pixels(valid, shape)
    field = (rng.random(shape) * (rng.random(shape) < 0.3)).astype(np.float32)
    cleared = np.where(inside, field, 0).astype(np.float32)
    field[~inside] = rng.random(int((~inside).sum())).astype(np.float32) + 5
    ours = _max_filter_blocks(field, blocks, half, valid)
    reference = cv2.dilate(cleared, np.ones((2 * half + 1, 2 * half + 1), np.uint8))
    wanted = _pixels(blocks, shape)
    np.testing.assert_array_equal(ours[wanted], reference[wanted])


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.float32])
@pytest.mark.parametrize("sigma_px", [2.887, 3.74])
def test_band_derivatives_equal_the_full_filters_inside_the_band(dtype, sigma_px) -> None:
    rng = np.random.default_rng(7)
    image = rng.integers(0, 255, (203, 301)).astype(dtype)
    grid = (-(-203 // BLOCK_PX), -(-301 // BLOCK_PX))
    blocks = np.zeros(grid, bool)
    blocks[3:9, :] = True  # a band across the frame, reaching both side edges
    blocks[:, 30:] = True  # and the bottom-right corner
    ring = np.zeros(grid, bool)
    ring[10:12, :20] = True
    band = band_derivatives(image, sigma_px, blocks, ring)
    full = gaussian_derivatives(image.astype(np.float32), sigma_px)
    inside = _pixels(blocks, (203, 301))
    zeroed = _pixels(ring, (203, 301))
    for name in ("ix", "iy", "ixx", "ixy", "iyy"):
        ours, reference = getattr(band, name), getattr(full, name)
        assert ours.dtype == np.float32
        scale = np.abs(reference[inside]).max()
        np.testing.assert_allclose(ours[inside], reference[inside], atol=2e-6 * scale)
    assert not band.ix[zeroed].any() and not band.iy[zeroed].any()


@pytest.mark.parametrize("shape", [(6, 9), (20, 3), (1, 17)])
def test_band_derivatives_fold_borders_wider_than_the_image(shape) -> None:
    # A kernel radius (15 px at σ 3.74) beyond the image: the border folds more than once.
    image = np.random.default_rng(3).integers(0, 255, shape).astype(np.float32)
    grid = (-(-shape[0] // BLOCK_PX), -(-shape[1] // BLOCK_PX))
    blocks = np.ones(grid, bool)
    band = band_derivatives(image, 3.74, blocks, ~blocks)
    full = gaussian_derivatives(image, 3.74)
    for name in ("ix", "iy", "ixx", "ixy", "iyy"):  # float32 sums in another order
        np.testing.assert_allclose(getattr(band, name), getattr(full, name), atol=2e-6 * 255)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), density=st.floats(0.05, 0.6))
def test_run_labelling_matches_opencv_components(seed, density) -> None:
    rng = np.random.default_rng(seed)
    binary = rng.random((40, 56)) < density
    blocks = np.ones((5, 7), bool)
    runs = row_runs(binary, blocks)
    label, moments = label_runs(runs)
    count, labels = cv2.connectedComponents(binary.astype(np.uint8), connectivity=8)
    assert moments.shape[0] == count
    ours = np.zeros(binary.shape, np.int64)
    for (row, first, stop), k in zip(runs, label, strict=True):
        ours[row, first:stop] = k
    # The same partition: each of our labels is one OpenCV label and vice versa.
    pairs = {(a, b) for a, b in zip(ours[binary], labels[binary], strict=True)}
    assert len(pairs) == count - 1 == len({a for a, _ in pairs}) == len({b for _, b in pairs})
    rows, cols = np.nonzero(binary)
    np.testing.assert_allclose(
        moments[:, 0], np.bincount(ours[binary], minlength=count).astype(float)
    )
    np.testing.assert_allclose(
        moments[:, 5], np.bincount(ours[binary], weights=rows * cols, minlength=count)
    )


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**31 - 1),
    shape=st.tuples(st.integers(9, 70), st.integers(9, 70)),
    density=st.floats(0.05, 0.95),
    whole=st.booleans(),
    scratch=st.integers(0, 255),
)
def test_band_closing_is_the_opencv_closing(seed, shape, density, whole, scratch) -> None:
    rng = np.random.default_rng(seed)
    grid = (-(-shape[0] // BLOCK_PX), -(-shape[1] // BLOCK_PX))
    blocks = np.ones(grid, bool) if whole else rng.random(grid) < 0.7
    band = _pixels(blocks, shape, np.uint8)
    # The mask beyond CLOSING_REACH_PX of the band's edge (the frame's edge is band).
    square = np.ones((2 * CLOSING_REACH_PX + 1,) * 2, np.uint8)
    band = cv2.erode(band, square, borderType=cv2.BORDER_CONSTANT, borderValue=1)
    mask = (rng.random(shape) < density) & (band > 0)
    runs = row_runs(mask, blocks)
    chosen = np.ones(len(runs), bool)
    assert not runs_near_band_edge(runs, blocks, CLOSING_REACH_PX).any()
    dilated = np.full(shape, scratch, np.uint8)  # whatever the scratch array held before
    ours = close_runs(runs, chosen, blocks, shape, dilated=dilated)
    assert ours.dtype == bool and ours.shape == shape
    np.testing.assert_array_equal(ours, close_holes(mask))
