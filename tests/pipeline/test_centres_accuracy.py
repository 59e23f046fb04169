"""Accuracy bars of issue 3 on synthetic wheel stripes with exact truth (see stripe_images)."""

from __future__ import annotations

import functools

import pytest

from pipeline import extract_centres
from tests.pipeline.stripe_images import StripeCase, make_stripe
from tests.pipeline.stripe_scores import score_centres

UNIFORM = [
    StripeCase("uniform-w5", width_start_px=5, width_end_px=5),
    StripeCase("uniform-w13", width_start_px=13, width_end_px=13),
    StripeCase("uniform-w21", width_start_px=21, width_end_px=21),
]
VARYING = [
    StripeCase("varying-clean"),
    StripeCase("varying-noise3", read_noise=3, shot_noise=True),
    StripeCase("varying-noise10", read_noise=10, shot_noise=True),
    StripeCase("low-grey", read_noise=3, shot_noise=True, low_grey=True),
    StripeCase("clutter-other-part", read_noise=3, shot_noise=True, clutter=True, other_part=True),
    StripeCase("saturated", read_noise=3, shot_noise=True, saturation=True),
    StripeCase("16-bit", read_noise=3, shot_noise=True, bits=16),
]


@functools.cache
def _score_both(case: StripeCase):
    stripe = make_stripe(case)
    adaptive = extract_centres(stripe.image, "adaptive")
    steger = extract_centres(stripe.image, "steger")
    return (
        case,
        score_centres(stripe, adaptive.x, adaptive.y),
        score_centres(stripe, steger.x, steger.y),
    )


@pytest.fixture(scope="module", params=UNIFORM + VARYING, ids=lambda c: c.name)
def scored(request):
    return _score_both(request.param)


def test_adaptive_rms_within_bar(scored) -> None:
    case, adaptive, _ = scored
    bar = 0.03 if case in UNIFORM else 0.05
    assert adaptive.rms_px <= bar, adaptive


def test_adaptive_leaves_no_gap_along_the_stripe(scored) -> None:
    _, adaptive, _ = scored
    assert adaptive.max_gap_px == 0, adaptive
    assert adaptive.coverage_pct == 100


def test_adaptive_false_points_within_bar(scored) -> None:
    _, adaptive, _ = scored
    assert adaptive.false_pct <= 0.2, adaptive


@pytest.mark.parametrize("case", VARYING, ids=lambda c: c.name)
def test_adaptive_twice_as_accurate_as_steger_where_width_varies(case: StripeCase) -> None:
    _, adaptive, steger = _score_both(case)
    assert 2 * adaptive.rms_px <= steger.rms_px, (adaptive, steger)


def test_steger_rejects_other_parts_and_spots_too() -> None:
    stripe = make_stripe(
        StripeCase("clutter", read_noise=3, shot_noise=True, clutter=True, other_part=True)
    )
    for method in ("steger", "classic"):
        centres = extract_centres(stripe.image, method)
        assert score_centres(stripe, centres.x, centres.y).false_pct <= 0.2, method
