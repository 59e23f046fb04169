"""The band path (the camera-rate default) against the full-frame reference path."""

from __future__ import annotations

import functools
from dataclasses import replace

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import pipeline.extraction.band_analysis as band_analysis
from pipeline import extract_centres
from pipeline.extraction.band import BLOCK_PX
from pipeline.extraction.band_filters import band_derivatives
from pipeline.extraction.band_segmentation import (
    CLOSING_REACH_PX,
    _label_runs,
    _row_runs,
    _runs_near_band_edge,
    close_band,
)
from pipeline.extraction.gaussian import gaussian_derivatives
from pipeline.extraction.segmentation import close_holes
from tests.pipeline.stripe_images import StripeCase, make_stripe
from tests.pipeline.test_centres_accuracy import UNIFORM, VARYING
from tests.pipeline.test_steger import straight_stripe

FULL_FRAME = (1200, 1600)
CASES = [
    *UNIFORM,
    *VARYING,
    replace(StripeCase("frame-clean"), shape=FULL_FRAME),
    replace(
        StripeCase("frame-clutter", read_noise=3, shot_noise=True, clutter=True, other_part=True),
        shape=FULL_FRAME,
    ),
]
ACROSS_TOLERANCE_PX = 1e-3
"""Largest move of a centre across the stripe between the paths (float rounding)."""

ALONG_TOLERANCE_PX = 0.5
"""Largest move along it: where the line passes a pixel boundary two pixels tie for one
centre (|t·n| = 0.5) and rounding may give it to the other (seen: 0.087 px)."""


def _assert_same_points(band, full) -> None:
    assert len(band) == len(full)
    dx, dy = band.x - full.x, band.y - full.y
    across = np.abs(dx * full.nx + dy * full.ny)
    along = np.abs(-dx * full.ny + dy * full.nx)
    assert across.max(initial=0) <= ACROSS_TOLERANCE_PX
    assert along.max(initial=0) <= ALONG_TOLERANCE_PX


@functools.cache
def _both(case: StripeCase, method: str):
    image = make_stripe(case).image
    return extract_centres(image, method), extract_centres(image, method, full_frame=True)


@pytest.mark.parametrize("method", ["adaptive", "steger"])
@pytest.mark.parametrize("case", CASES, ids=lambda c: c.name)
def test_band_path_gives_the_full_frame_result(case: StripeCase, method: str) -> None:
    band, full = _both(case, method)
    assert band.path == "band"
    assert full.path == "full"
    np.testing.assert_array_equal(band.mask, full.mask)
    _assert_same_points(band, full)
    np.testing.assert_array_equal(band.sigma, full.sigma)
    if method == "adaptive":
        np.testing.assert_array_equal(band.sigma_map, full.sigma_map)


def test_a_frame_without_stripe_has_no_centres_on_either_path() -> None:
    rng = np.random.default_rng(3)
    image = np.clip(12 + rng.normal(0, 3, FULL_FRAME), 0, 255).astype(np.uint8)
    band = extract_centres(image)
    assert band.path == "band"
    assert len(band) == 0 and not band.mask.any()
    assert len(extract_centres(image, full_frame=True)) == 0


def test_a_frame_the_band_cannot_cover_falls_back_to_the_full_frame() -> None:
    # Bright ridges everywhere (a grating): the band would be most of the frame.
    rows = np.arange(FULL_FRAME[0], dtype=np.float64)[:, None]
    image = np.broadcast_to(12 + 150 * (np.sin(rows / 9.0) > 0.6), FULL_FRAME).astype(np.uint8)
    band = extract_centres(image)
    full = extract_centres(image, full_frame=True)
    assert band.path == "fallback"
    np.testing.assert_array_equal(band.x, full.x)


def test_classic_always_takes_the_full_frame() -> None:
    assert extract_centres(make_stripe(UNIFORM[1]).image, "classic").path == "full"


@settings(max_examples=15, deadline=None)
@given(
    angle_deg=st.floats(-80, 80),
    offset_px=st.floats(-20, 20),
    width_px=st.floats(5, 21),
)
def test_band_path_equals_full_frame_on_straight_stripes(angle_deg, offset_px, width_px) -> None:
    image = straight_stripe(angle_deg, offset_px, width_px, shape=(240, 320))
    band = extract_centres(image)
    full = extract_centres(image, full_frame=True)
    assert band.path == "band"
    np.testing.assert_array_equal(band.mask, full.mask)
    _assert_same_points(band, full)


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
    inside = np.kron(blocks, np.ones((BLOCK_PX, BLOCK_PX), bool))[:203, :301]
    zeroed = np.kron(ring, np.ones((BLOCK_PX, BLOCK_PX), bool))[:203, :301]
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
    runs = _row_runs(binary, blocks)
    label, moments = _label_runs(runs)
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


def _bands_tried(monkeypatch) -> list:
    """Record every band the band path locates from now on (a spy on `locate_band`)."""
    tried = []
    real = band_analysis.locate_band

    def spy(*args, **kwargs):
        tried.append(real(*args, **kwargs))
        return tried[-1]

    monkeypatch.setattr(band_analysis, "locate_band", spy)
    return tried


def test_stray_spots_are_left_out_of_the_band(monkeypatch) -> None:
    _, full = _both(CASES[-1], "adaptive")  # frame-clutter
    tried = _bands_tried(monkeypatch)
    again = extract_centres(make_stripe(CASES[-1]).image)
    assert len(tried) == 1 and tried[0].left_out_px > 0
    np.testing.assert_array_equal(again.mask, full.mask)
    np.testing.assert_array_equal(again.sigma_map, full.sigma_map)


def test_a_short_stripe_left_out_beside_a_faint_long_ridge_is_taken_back(monkeypatch) -> None:
    # The long faint ridge makes the largest seed region but no stripe (V < 0.5); the 75 px
    # stripe's region looks small beside it, and the band first leaves it out.
    rows, cols = np.mgrid[0:1200, 0:1600].astype(np.float64)
    image = 12 + 8 * np.exp(-2 * ((rows - 300) / 6) ** 2)
    image += 150 * np.exp(-2 * ((rows - 800) / 4.5) ** 2) * ((cols > 700) & (cols < 775))
    image = image.astype(np.uint8)
    tried = _bands_tried(monkeypatch)
    band = extract_centres(image)
    full = extract_centres(image, full_frame=True)
    assert [b.left_out_px > 0 for b in tried] == [True, False]
    assert band.path == "band" and len(full) > 50
    np.testing.assert_array_equal(band.mask, full.mask)
    _assert_same_points(band, full)


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**31 - 1),
    shape=st.tuples(st.integers(9, 70), st.integers(9, 70)),
    density=st.floats(0.05, 0.95),
    deep=st.booleans(),
    scratch=st.integers(0, 255),
)
def test_band_closing_is_the_full_frame_closing(seed, shape, density, deep, scratch) -> None:
    rng = np.random.default_rng(seed)
    grid = (-(-shape[0] // BLOCK_PX), -(-shape[1] // BLOCK_PX))
    blocks = rng.random(grid) < 0.7
    band = np.kron(blocks, np.ones((BLOCK_PX, BLOCK_PX), np.uint8))[: shape[0], : shape[1]]
    if deep:  # the mask beyond CLOSING_REACH_PX of the band's edge (the frame's edge is band)
        square = np.ones((2 * CLOSING_REACH_PX + 1,) * 2, np.uint8)
        band = cv2.erode(band, square, borderType=cv2.BORDER_CONSTANT, borderValue=1)
    mask = (rng.random(shape) < density) & (band > 0)
    runs = _row_runs(mask, blocks)
    chosen = np.ones(len(runs), bool)
    if deep:  # the kernels on the band, not the full-frame fallback
        assert not _runs_near_band_edge(runs, blocks, CLOSING_REACH_PX).any()
    dilated = np.full(shape, scratch, np.uint8)  # whatever the scratch array held before
    ours = close_band(runs, chosen, blocks, shape, dilated=dilated)
    assert ours.dtype == bool and ours.shape == shape
    np.testing.assert_array_equal(ours, close_holes(mask))
