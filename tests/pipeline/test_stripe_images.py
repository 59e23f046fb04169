"""The synthetic stripe generator's truth is right: centre, width, laser pixels, scene, noise."""

from __future__ import annotations

import functools

import cv2
import numpy as np
import pytest
from scipy.spatial import cKDTree

from tests.pipeline.stripe_images import (
    BACKGROUND_GREY,
    BROKEN_GAINS,
    BROKEN_SHIFTS_PX,
    BROKEN_WIDTHS_PX,
    SHOT_GAIN,
    TRUTH_STEP_PX,
    StripeCase,
    make_stripe,
    noise_bound_px,
    project_on_line,
    wheel_line,
)
from tests.pipeline.stripe_scenes import SCENE_GREY_RANGE, lit_scene
from tests.pipeline.stripe_scores import score_centres

QUIET = {"bits": 16}  # no noise, quantisation 1/257 grey


@functools.cache
def _made(case: StripeCase):
    """Each frame rendered once for the module (about 1 s each)."""
    return make_stripe(case)


def _cross_sections(stripe, *, straight=False):
    """Per pixel near the truth: signed distance across it, its segment, the laser's grey.

    With `straight`, only where the line turns by < 0.5° over ±10 px of arc: on a curve the
    pixels' area per unit arc grows outward, which moves an intensity centroid by ≈ κs².
    """
    rows, cols = np.nonzero(cv2.dilate(stripe.laser_mask.astype(np.uint8), np.ones((31, 31))))
    xy = np.stack([cols, rows], axis=1).astype(float)
    line = stripe.line_xy
    foot = project_on_line(cKDTree(line), line, stripe.arc_px, xy, stripe.segment)
    keep = (foot.distance_px < stripe.width_px[foot.index]) & ~stripe.end_zone[foot.index]
    if straight:
        heading = np.unwrap(np.arctan2(*np.gradient(line, axis=0).T[::-1]))
        reach = int(10 / TRUTH_STEP_PX)
        k = foot.index
        ahead = np.clip(k + reach, 0, len(line) - 1)
        behind = np.clip(k - reach, 0, len(line) - 1)
        turn = np.abs(heading[ahead] - heading[behind])
        same = (stripe.segment[ahead] == stripe.segment[k]) & (
            stripe.segment[behind] == stripe.segment[k]
        )
        keep &= (turn < np.deg2rad(0.5)) & same
    grey = stripe.image[rows, cols] / 257 - BACKGROUND_GREY
    return foot.side[keep] * foot.distance_px[keep], stripe.segment[foot.index][keep], grey[keep]


def test_each_segment_is_centred_on_its_truth_with_its_width() -> None:
    stripe = _made(StripeCase("broken", broken=True, **QUIET))
    signed, segment, grey = _cross_sections(stripe, straight=True)
    assert len(np.unique(stripe.segment)) == len(BROKEN_WIDTHS_PX)
    assert len(np.unique(segment)) >= 4  # the others lie on the flange's curves
    for i in np.unique(segment):
        d, w = signed[segment == i], grey[segment == i]
        # Intensity-weighted mean and spread across the stripe: 0 and the Gaussian's s = w/4
        # (its tails beyond |d| = w hold 0.03 % of the weight).
        assert abs(np.sum(w * d) / np.sum(w)) < 0.01, i
        assert np.sqrt(np.sum(w * d**2) / np.sum(w)) == pytest.approx(
            BROKEN_WIDTHS_PX[i] / 4, rel=0.01
        ), i


def test_segments_are_shifted_apart_and_at_their_own_peaks() -> None:
    stripe = _made(StripeCase("broken", broken=True, **QUIET))
    unbroken = wheel_line(stripe.image.shape)
    arc = np.concatenate([[0], np.cumsum(np.hypot(*np.diff(unbroken, axis=0).T))])
    for i, shift in enumerate(BROKEN_SHIFTS_PX):
        samples = stripe.line_xy[stripe.segment == i]
        source = unbroken[np.searchsorted(arc, stripe.arc_px[stripe.segment == i])]
        assert np.allclose(samples - source, [0, shift], atol=1e-9), i
        inner = samples[~stripe.end_zone[stripe.segment == i]]
        inner = inner[(inner >= 0).all(axis=1) & (inner < [639.5, 399.5]).all(axis=1)]
        c, r = np.rint(inner).astype(int).T
        peak = stripe.image[r, c] / 257 - BACKGROUND_GREY
        assert peak.max() == pytest.approx(170 * BROKEN_GAINS[i], rel=0.01), i


def test_laser_mask_holds_the_pixels_lit_to_e2_of_the_peak() -> None:
    stripe = _made(StripeCase("plain", **QUIET))
    laser = stripe.image / 257 - BACKGROUND_GREY
    assert laser[stripe.laser_mask].min() >= 170 * np.exp(-2) * 0.98
    assert laser[~stripe.laser_mask].max() <= 170 * np.exp(-2) * 1.02


def test_asymmetric_stripe_is_dimmer_on_one_side_about_the_same_centre() -> None:
    stripe = _made(StripeCase("asymmetric", asymmetry=0.5, **QUIET))
    signed, _, grey = _cross_sections(stripe)
    left, right = grey[signed < -1].sum(), grey[signed > 1].sum()
    assert left / right == pytest.approx(0.5, rel=0.02)


def test_ghost_lies_beside_the_stripe_at_its_ratio() -> None:
    stripe = _made(StripeCase("ghost", ghost_ratio=0.2, **QUIET))
    (ghost,) = stripe.extras
    assert cKDTree(stripe.line_xy).query(ghost)[0].min() > 25
    c, r = np.rint(ghost[len(ghost) // 2]).astype(int)
    assert stripe.image[r, c] / 257 - BACKGROUND_GREY == pytest.approx(0.2 * 170, rel=0.02)


@pytest.mark.parametrize("layout", ["lit", "lit-crossing"])
def test_lit_scene_grey_range_and_texture_correlation(layout: str) -> None:
    scene = lit_scene(np.random.default_rng(0), (400, 640), layout, 0.05)
    low, high = SCENE_GREY_RANGE
    assert scene.grey.min() >= low and scene.grey.max() <= high
    patch = scene.grey[60:140, 330:420]  # dim ambient, no plate
    patch = (patch - patch.mean()) / patch.std()
    lag5 = np.mean(patch[:, 5:] * patch[:, :-5])
    assert 0.2 < lag5 < 0.55  # e^(-25/(4·2.5²)) = 0.37


@pytest.mark.parametrize(
    ("layout", "crosses"), [("lit", False), ("lit-specular", False), ("lit-crossing", True)]
)
def test_scene_lines_stay_beside_the_stripe_or_cross_it(layout: str, crosses: bool) -> None:
    stripe = _made(StripeCase(layout, scene=layout, **QUIET))
    tree = cKDTree(stripe.line_xy)
    nearest = [tree.query(line)[0].min() for line in stripe.extras]
    if crosses:
        assert all(d < 1 for d in nearest), nearest
    else:
        assert min(nearest) > 20, nearest


def test_speckle_modulates_the_stripe_by_its_contrast() -> None:
    plain = _made(StripeCase("plain", **QUIET))
    grainy = _made(StripeCase("speckle", speckle=0.1, **QUIET))
    lit = plain.laser_mask
    ratio = (grainy.image[lit] / 257 - BACKGROUND_GREY) / (plain.image[lit] / 257 - BACKGROUND_GREY)
    assert ratio.mean() == pytest.approx(1, abs=0.01)
    assert ratio.std() == pytest.approx(0.1, rel=0.1)
    assert np.array_equal(grainy.line_xy, plain.line_xy)


def test_noise_of_the_noise_case() -> None:
    stripe = _made(StripeCase("noise", read_noise=10, shot_noise=True, peak_grey=120))
    flat = stripe.image[300:380, 20:60].astype(float)  # dark background, no stripe
    sigma = np.sqrt(10**2 + SHOT_GAIN * BACKGROUND_GREY)
    # The same noise drawn on its own, rounded and clipped at 0 as the frame is.
    drawn = np.random.default_rng(1).normal(BACKGROUND_GREY, sigma, 200_000)
    assert flat.std() == pytest.approx(np.clip(np.rint(drawn), 0, 255).std(), rel=0.05)


def test_flare_radiates_from_the_stripe_and_is_not_laser() -> None:
    plain = _made(StripeCase("plain", **QUIET))
    flared = _made(StripeCase("flare", flare=True, **QUIET))
    assert np.array_equal(flared.laser_mask, plain.laser_mask)
    starts = np.array([streak[0] for streak in flared.extras])
    origin = starts.mean(axis=0)
    assert np.allclose(np.hypot(*(starts - origin).T), 8.0, atol=1e-6)
    assert cKDTree(flared.line_xy).query(origin)[0] < 0.05


@pytest.mark.parametrize("width_px", [5.0, 13.0, 21.0])
def test_noise_bound_is_the_fisher_bound_of_a_sampled_profile(width_px: float) -> None:
    amplitude, sigma_n = 120.0, 10.0
    x = np.arange(-40, 41) - 0.3
    s = width_px / 4
    slope = amplitude * x / s**2 * np.exp(-(x**2) / (2 * s**2))
    one_d = sigma_n / np.sqrt(np.sum(slope**2))
    support_px = 2 * np.sqrt(np.pi) * width_px / np.sqrt(3)
    bound = noise_bound_px(
        np.array([amplitude]),
        np.array([0.0]),
        np.array([width_px]),
        read_noise=sigma_n,
        shot_noise=False,
        bits=16,
    )
    assert bound[0] * np.sqrt(support_px) == pytest.approx(one_d, rel=0.01)


def test_scores_of_the_truth_itself_and_of_wrong_points() -> None:
    stripe = _made(StripeCase("broken", broken=True, **QUIET))
    x, y = stripe.line_xy[::10].T
    exact = score_centres(stripe, x, y)
    assert exact.rms_px < 1e-9 and exact.false_pct == 0 and exact.max_gap_px == 0
    assert exact.segment_coverage_pct == (100.0,) * len(BROKEN_WIDTHS_PX)
    normal = np.gradient(stripe.line_xy, axis=0)[::10, ::-1] * [1, -1] / TRUTH_STEP_PX
    assert score_centres(stripe, x + 4 * normal[:, 0], y + 4 * normal[:, 1]).false_pct > 99
    keep = stripe.segment[::10] != 2
    missing = score_centres(stripe, x[keep], y[keep])
    assert missing.segment_coverage_pct[2] == 0
    assert min(np.delete(missing.segment_coverage_pct, 2)) == 100
