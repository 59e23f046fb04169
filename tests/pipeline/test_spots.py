"""Round spots are not lines (`line_test.is_spot`): a glint beside or on the stripe keeps no
centre, the stripe keeps all of its own."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
from hypothesis import example, given, settings
from hypothesis import strategies as st

from pipeline import extract_centres
from pipeline.extraction import line_test
from pipeline.extraction.centres import _no_spots

SHAPE = (240, 400)


def _spot(rows, cols, x, y, sigma_px, peak):
    return peak * np.exp(-0.5 * ((cols - x) ** 2 + (rows - y) ** 2) / sigma_px**2)


def _bend(rows, cols, width_px, peak, radius_px=60.0):
    """A stripe along row 60 from x = 20 to 200, then bending down on a circle of
    `radius_px` (centre (200, 60 + radius)) to the vertical; distance to its centre line [px]
    per pixel, and the line's (x, y) truth every 0.5 px."""
    cx, cy = 200.0, 60.0 + radius_px
    straight = np.where(cols <= cx, np.abs(rows - 60.0), np.inf)
    straight = np.where(cols >= 20, straight, np.inf)
    arc = np.abs(np.hypot(cols - cx, rows - cy) - radius_px)
    arc = np.where((cols >= cx) & (rows <= cy), arc, np.inf)
    down = np.where(rows >= cy, np.abs(cols - cx - radius_px), np.inf)
    down = np.where(rows <= SHAPE[0] - 20, down, np.inf)
    distance = np.minimum(np.minimum(straight, arc), down)
    image = peak * np.exp(-8 * distance**2 / width_px**2)
    angles = np.linspace(-np.pi / 2, 0, int(np.pi / 2 * radius_px * 2))
    along = np.arange(20.0, cx, 0.5)
    down_y = np.arange(cy, SHAPE[0] - 20, 0.5)
    truth = np.vstack(
        [
            np.column_stack([along, np.full(along.size, 60.0)]),
            np.column_stack([cx + radius_px * np.cos(angles), cy + radius_px * np.sin(angles)]),
            np.column_stack([np.full(down_y.size, cx + radius_px), down_y]),
        ]
    )
    return image, truth


def _frame(image, seed=0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.clip(np.rint(12 + image + rng.normal(0, 2.0, image.shape)), 0, 255).astype(np.uint8)


def _covered(centres, truth, reach_px=1.0) -> float:
    """Share of the truth line's samples (away from its ends) with a centre within reach."""
    inner = truth[10:-10]
    d = np.hypot(inner[:, None, 0] - centres.x[None], inner[:, None, 1] - centres.y[None])
    return float((d.min(axis=1) <= reach_px).mean()) if centres.x.size else 0.0


SPOTS_BESIDE = [(80.0, 74.5, 2.0, 200.0), (150.0, 41.0, 3.5, 120.0), (247.0, 150.0, 1.5, 255.0)]
"""Glints beside the stripe as the simulator draws them on the flange: (x, y, σ [px], peak
[grey levels]), clear of the stripe's 1/e² edge (w/2) by 3σ + 4 px, in its mask."""
SPOTS_ON = [(120.0, 60.5, 1.5, 200.0), (261.0, 160.0, 2.5, 150.0)]
"""Glints on the stripe's line (within w/8 of it)."""


def test_no_centre_is_kept_on_a_spot_and_the_stripe_keeps_its_coverage() -> None:
    rows, cols = np.mgrid[0 : SHAPE[0], 0 : SHAPE[1]].astype(np.float64)
    stripe, truth = _bend(rows, cols, width_px=9.0, peak=150.0)
    spots = sum(_spot(rows, cols, *spot) for spot in SPOTS_BESIDE + SPOTS_ON)
    clean = extract_centres(_frame(stripe), width_min=5, width_max=21)
    spotted = extract_centres(_frame(stripe + spots), width_min=5, width_max=21)
    subtracted = extract_centres(
        _frame(stripe + spots), width_min=5, width_max=21, glint_subtraction=True
    )
    assert _covered(clean, truth) > 0.99
    assert _covered(spotted, truth) >= _covered(clean, truth) - 0.005
    assert _covered(subtracted, truth) >= _covered(clean, truth) - 0.005
    for x, y, sigma_px, _ in SPOTS_BESIDE:
        for found in (spotted, subtracted):
            near = np.hypot(found.x - x, found.y - y) < 3 * sigma_px + 2
            assert not near.any(), (x, y)
        assert (np.hypot(spotted.rejected_x - x, spotted.rejected_y - y) < 3 * sigma_px).any()
    # On the stripe, its own centres stay on its line; the spot's crossing chains go.
    for x, y, sigma_px, _ in SPOTS_ON:
        near = np.hypot(spotted.x - x, spotted.y - y) < 3 * sigma_px + 2
        assert near.sum() >= 2 * sigma_px
        off_line = np.hypot(
            spotted.x[near, None] - truth[None, :, 0], spotted.y[near, None] - truth[None, :, 1]
        ).min(axis=1)
        assert off_line.max() < 1.0, (x, y)  # pulled towards the glint, not beyond it


@settings(max_examples=12, deadline=None, derandomize=True)
@given(
    sigma_px=st.floats(5.0 / 4, 21.0 / 4),
    peak=st.floats(60.0, 240.0),
    x=st.floats(60.0, 160.0),
    gap_px=st.floats(3.0, 8.0),
    side=st.sampled_from([-1.0, 1.0]),
)
def test_a_round_spot_of_any_size_in_the_width_range_beside_the_stripe_keeps_no_centre(
    sigma_px, peak, x, gap_px, side
) -> None:
    # A spot whose 1/e² width (4σ) is a stripe width of the range, as close beside the
    # stripe (w 9 px, along row 60) as the simulator draws them: clear of its edge by 3σ + gap.
    rows, cols = np.mgrid[0 : SHAPE[0], 0 : SHAPE[1]].astype(np.float64)
    stripe, truth = _bend(rows, cols, width_px=9.0, peak=150.0)
    y = 60.0 + side * (4.5 + 3 * sigma_px + gap_px)
    centres = extract_centres(
        _frame(stripe + _spot(rows, cols, x, y, sigma_px, peak)), width_min=5, width_max=21
    )
    assert not (np.hypot(centres.x - x, centres.y - y) < 3 * sigma_px + 2).any()
    assert _covered(centres, truth) > 0.99


@settings(max_examples=12, deadline=None, derandomize=True)
@given(width_px=st.floats(5.0, 21.0), radius_px=st.floats(30.0, 80.0), peak=st.floats(60.0, 240.0))
@example(width_px=13.0, radius_px=30.515625, peak=63.0)  # 98.85 % covered with or without the rule
def test_a_straight_and_bent_stripe_of_any_width_in_range_keeps_full_coverage(
    width_px, radius_px, peak
) -> None:
    # The rule takes no centre of a stripe: the same centres with it as without it, and the
    # stripe covered. (A dim, tight bend - w 13 px, R 30.5 px, peak 63 - is 98.85 % covered
    # with the rule off too: the loss is the bend's, not the rule's, hence the 0.98.)
    rows, cols = np.mgrid[0 : SHAPE[0], 0 : SHAPE[1]].astype(np.float64)
    stripe, truth = _bend(rows, cols, width_px=width_px, peak=peak, radius_px=radius_px)
    centres = extract_centres(_frame(stripe), width_min=5, width_max=21)
    ratio = line_test.SPOT_RATIO
    line_test.SPOT_RATIO = float("inf")
    try:
        without_rule = extract_centres(_frame(stripe), width_min=5, width_max=21)
    finally:
        line_test.SPOT_RATIO = ratio
    np.testing.assert_array_equal(centres.x, without_rule.x)
    np.testing.assert_array_equal(centres.y, without_rule.y)
    assert _covered(centres, truth, reach_px=1.5) > 0.98


def test_a_spot_chain_that_continues_the_stripes_line_is_kept_one_beside_it_is_not() -> None:
    # Chains 1 px apart along x: the stripe's long chain (λ2/λ1 0, height 60) ending at
    # x = 99, and 9-centre chains highest at a glint (λ2/λ1 0.95 there, height 200): one on
    # the stripe's line past a 4 px break (the stripe's own, broken at the glint on a
    # textured surface), one 12 px beside it (a glint beside the stripe).
    stripe = np.column_stack([np.arange(0.0, 100.0), np.zeros(100)])
    ahead = np.column_stack([np.arange(104.0, 113.0), np.zeros(9)])
    beside = np.column_stack([np.arange(40.0, 49.0), np.full(9, 12.0)])
    xy = np.vstack([stripe, ahead, beside])
    glint = np.r_[np.zeros(100), np.tile([0.3, 0.5, 0.7, 0.9, 0.95, 0.9, 0.7, 0.5, 0.3], 2)]
    height = np.r_[np.full(100, 60.0), np.tile([60, 90, 140, 180, 200, 180, 140, 90, 60], 2)]
    chains = [np.arange(100), np.arange(100, 109), np.arange(109, 118)]
    selected = SimpleNamespace(lambda_ratio=glint, sigma=np.full(xy.shape[0], 2.9))
    kept, spots = _no_spots(chains, height.astype(float), selected, xy)
    assert [c[0] for c in kept] == [0, 100]
    assert np.array_equal(spots, np.arange(109, 118))


@settings(max_examples=200, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), points=st.integers(1, 80))
def test_spot_chains_judges_every_chain_as_is_spot_does(seed: int, points: int) -> None:
    """The all-chains-at-once judgement (`line_test.spot_chains`: each chain's highest centre
    by `chain_tops`, then `is_spot` where λ2/λ1 there reaches SPOT_RATIO) is `is_spot` of
    each chain, ties and NaN heights included."""
    rng = np.random.default_rng(seed)
    height = rng.integers(0, 4, points).astype(float)  # few values: ties
    height[rng.random(points) < 0.05] = np.nan
    ratio = rng.choice([0.0, 0.59, 0.6, 0.9, 1.0], points)
    sigma = rng.choice([2.9, 7.5], points)
    xy = np.cumsum(rng.normal(0, 3, (points, 2)), axis=0)
    cuts = np.sort(rng.choice(np.arange(1, points), rng.integers(0, points), replace=False))
    chains = np.split(rng.permutation(points), cuts)
    expected = [line_test.is_spot(xy[c], height[c], ratio[c], sigma[c]) for c in chains]
    tops = [c[np.argmax(height[c])] for c in chains]
    np.testing.assert_array_equal(line_test.chain_tops(height, chains), tops)
    np.testing.assert_array_equal(line_test.spot_chains(xy, height, ratio, sigma, chains), expected)
