"""Issue-15 bars on the field-harsh synthetic stripes (stripe_images, docs/extraction-cases.md).

Every case: each segment ≥ 99 % covered (truth within 2.5 px of a centre), false points
≤ 0.5 % on a lit, textured, edged scene and ≤ 0.2 % on a dark one, RMS ≤ 0.05 px; the noise
case: RMS ≤ 1.5× its noise bound. Where the adaptive method does not yet reach a bar the test
is an expected failure (strict: it fails once the bar is met, so the mark must go); the
figures measured when the cases were added are in each reason.
"""

from __future__ import annotations

import functools

import pytest

from pipeline import extract_centres
from tests.pipeline.bars import bar_params
from tests.pipeline.stripe_images import StripeCase, make_stripe
from tests.pipeline.stripe_scores import Score, score_centres

HARSH = [
    StripeCase("lit-textured", read_noise=3, shot_noise=True, scene="lit"),
    StripeCase("broken-steps", read_noise=3, shot_noise=True, broken=True),
    StripeCase("lit-edge-crossing", read_noise=3, shot_noise=True, scene="lit-crossing"),
    StripeCase("ghost-20", read_noise=3, shot_noise=True, ghost_ratio=0.2),
    StripeCase("asymmetric-0.5", read_noise=3, shot_noise=True, asymmetry=0.5),
    StripeCase("noise-peak120", read_noise=10, shot_noise=True, peak_grey=120),
    StripeCase("lit-specular", read_noise=3, shot_noise=True, scene="lit-specular"),
    StripeCase("speckle-0.1", read_noise=3, shot_noise=True, speckle=0.1),
    StripeCase("flare", read_noise=3, shot_noise=True, flare=True),
    StripeCase(
        "field-all",
        read_noise=3,
        shot_noise=True,
        scene="lit-specular",
        broken=True,
        ghost_ratio=0.2,
        speckle=0.1,
        flare=True,
    ),
]
CASES = {case.name: case for case in HARSH}
NOISE_CASE = "noise-peak120"
COVERAGE_BAR_PCT = 99.0
RMS_BAR_PX = 0.05
BOUND_BAR_RATIO = 1.5

NOT_YET = {
    ("lit-textured", "rms"): "0.116 px (Hessian centres 0.174): the texture under the stripe "
    "(0.124 px with no sensor noise, 0.022 px with no texture; the sensor-noise bound 0.015, "
    "with the texture as correlated noise 0.061 px, docs/extraction-cases.md)",
    ("lit-edge-crossing", "rms"): "0.131 px (Hessian centres 0.233; bound with texture 0.095 px)",
    ("asymmetric-0.5", "rms"): "1.034 px (Hessian centres 0.938): the centre moves to the "
    "brighter side; the asymmetry correction's unequal-width model does not fit a "
    "reflectance step (1.61 px with it)",
    ("lit-specular", "rms"): "0.116 px (Hessian centres 0.174)",
    ("speckle-0.1", "rms"): "0.083 px (Hessian centres 0.111, Steger 0.232 px): grain on the "
    "stripe itself (0.088 px with no sensor noise; bound with the speckle 0.047 px)",
    ("field-all", "rms"): "0.205 px (Hessian centres 0.225; bound with texture 0.085 px)",
}


def false_bar_pct(case: StripeCase) -> float:
    """Issue 15: ≤ 0.5 % false points with a lit, textured, edged scene, ≤ 0.2 % on a dark one."""
    return 0.2 if case.scene == "dark" else 0.5


def missed_bars(case: StripeCase, score: Score) -> list[str]:
    """The bars `score` misses: "coverage", "false", "rms" (the noise case: RMS ÷ bound)."""
    rms_ok = (
        score.rms_to_bound <= BOUND_BAR_RATIO
        if case.name == NOISE_CASE
        else score.rms_px <= RMS_BAR_PX
    )
    checks = {
        "coverage": score.min_segment_coverage_pct >= COVERAGE_BAR_PCT,
        "false": score.false_pct <= false_bar_pct(case),
        "rms": rms_ok,
    }
    return [name for name, ok in checks.items() if not ok]


def harsh_verdict(case: StripeCase, score: Score) -> str:
    """PASS, or FAIL and the bars missed (benchmark column)."""
    missed = missed_bars(case, score)
    return f"FAIL ({', '.join(missed)})" if missed else "PASS"


@functools.cache
def adaptive_score(case: StripeCase) -> Score:
    stripe = make_stripe(case)
    centres = extract_centres(stripe.image, "adaptive")
    return score_centres(stripe, centres.x, centres.y)


@pytest.mark.parametrize(
    ("metric", "name"), bar_params(CASES, ("coverage", "false", "rms"), NOT_YET)
)
def test_adaptive_meets_the_bar(metric: str, name: str) -> None:
    case = CASES[name]
    score = adaptive_score(case)
    assert metric not in missed_bars(case, score), score
