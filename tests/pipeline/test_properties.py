"""Property tests: centres follow transposes, flips and shifts of the frame, not its gain."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from scipy.spatial import cKDTree

from pipeline import extract_centres
from pipeline.extraction.centres import every_from_both_ends

SHAPE = (80, 112)
METHODS = st.sampled_from(["adaptive", "steger", "classic"])


def arc_stripe(radius_px: float, width_px: float, turn_deg: float, shape=SHAPE) -> np.ndarray:
    """A Gaussian stripe along a circular arc crossing the frame (float grey levels)."""
    rows, cols = np.mgrid[0 : shape[0], 0 : shape[1]].astype(float)
    turn = np.deg2rad(turn_deg)
    centre = np.array([shape[1] / 2, shape[0] / 2]) + (radius_px + 3.3) * np.array(
        [np.sin(turn), np.cos(turn)]
    )
    distance = np.hypot(cols - centre[0], rows - centre[1]) - radius_px
    return 12 + 170 * np.exp(-8 * distance**2 / width_px**2)


stripes = st.builds(
    arc_stripe,
    radius_px=st.floats(60, 300),
    width_px=st.floats(5, 15),
    turn_deg=st.floats(0, 360),
)


def matched_fraction(a_xy: np.ndarray, b_xy: np.ndarray, tolerance_px: float) -> float:
    """Fraction of points of `a` with a point of `b` within `tolerance_px`."""
    if len(a_xy) == 0 or len(b_xy) == 0:
        return 0.0
    distance, _ = cKDTree(b_xy).query(a_xy)
    return float(np.mean(distance <= tolerance_px))


def xy(centres) -> np.ndarray:
    return np.stack([centres.x, centres.y], axis=1)


def assert_transposed(grey: np.ndarray, method: str) -> None:
    """Centres of the transposed frame are the transposed centres (count within 1 %)."""
    image = np.rint(grey).astype(np.uint8)
    direct = extract_centres(image, method)
    transposed = extract_centres(np.ascontiguousarray(image.T), method)
    assert len(direct) > 50
    assert abs(len(direct) - len(transposed)) <= 0.01 * len(direct) + 1
    assert matched_fraction(xy(direct)[:, ::-1], xy(transposed), 1e-3) >= 0.98


# Derandomized so that CI is reproducible; a random run found the case below.
@settings(max_examples=8, deadline=None, derandomize=True)
@given(stripes, METHODS)
def test_transposing_the_frame_transposes_the_centres(grey, method) -> None:
    assert_transposed(grey, method)


@pytest.mark.xfail(
    strict=True,
    reason="classic: 125 centres direct, 133 transposed (r 125.8 px, w 5.07 px, turn 232.5°; "
    "the same on the previous release): an end of the arc at the frame's edge, not yet traced",
)
def test_transposing_an_arc_ending_at_the_frame_edge_transposes_the_classic_centres() -> None:
    assert_transposed(
        arc_stripe(125.77161326729238, 5.070918286031663, 232.45952240698122), "classic"
    )


@settings(max_examples=8, deadline=None, derandomize=True)
@given(stripes, METHODS, st.sampled_from([0, 1]))
def test_flipping_the_frame_flips_the_centres(grey, method, axis) -> None:
    image = np.rint(grey).astype(np.uint8)
    direct = extract_centres(image, method)
    flipped = extract_centres(np.ascontiguousarray(np.flip(image, axis=axis)), method)
    expected = xy(direct)
    expected[:, 1 - axis] = SHAPE[axis] - 1 - expected[:, 1 - axis]
    assert len(direct) > 50
    assert matched_fraction(expected, xy(flipped), 1e-3) >= 0.98


def assert_gain_keeps_centres(grey: np.ndarray, gain: float, method: str) -> None:
    """Centres of the frame scaled by `gain` (uint16) are the frame's, within 2·10⁻³ px."""
    image = np.rint(grey * 257).astype(np.uint16)
    scaled = np.rint(grey * 257 * gain).astype(np.uint16)
    direct = extract_centres(image, method)
    brighter = extract_centres(scaled, method)
    assert len(direct) > 50
    assert matched_fraction(xy(direct), xy(brighter), 2e-3) >= 0.98


# Derandomized like the transposing property: a random CI run found the case below.
@settings(max_examples=8, deadline=None, derandomize=True)
@given(stripes, st.floats(0.5, 1.5), st.sampled_from(["adaptive", "steger"]))
def test_intensity_gain_does_not_move_centres(grey, gain, method) -> None:
    # A gain that would push the peak past 65535 wraps uint16 around: not a gain any more.
    assume(float(grey.max()) * 257 * gain <= np.iinfo(np.uint16).max)
    assert_gain_keeps_centres(grey, gain, method)


# Gain exactly 0.5 on this arc once flipped the matched-kernel choice at its end by the
# frame's edge (centres moved up to 0.27 px); the end centres read along the interior's
# normal (pipeline 0.11.7, docs/extraction.md "Centres at a piece's end") hold it.
def test_halving_the_gain_of_a_wide_arc_keeps_the_adaptive_centres() -> None:
    assert_gain_keeps_centres(arc_stripe(300, 15, 45), 0.5, "adaptive")


@settings(max_examples=8, deadline=None, derandomize=True)
@given(
    st.floats(60, 300),
    st.floats(5, 15),
    st.floats(0, 360),
    st.floats(-6, 6),
    st.floats(-6, 6),
    METHODS,
)
def test_shifting_the_stripe_shifts_the_centres(radius, width, turn, dx, dy, method) -> None:
    shape = (128, 160)
    rows, cols = np.mgrid[0 : shape[0], 0 : shape[1]].astype(float)
    turn_rad = np.deg2rad(turn)
    centre = np.array([80.0, 64.0]) + (radius + 3.3) * np.array(
        [np.sin(turn_rad), np.cos(turn_rad)]
    )

    def render(offset: np.ndarray) -> np.ndarray:
        c = centre + offset
        distance = np.hypot(cols - c[0], rows - c[1]) - radius
        return np.rint((12 + 170 * np.exp(-8 * distance**2 / width**2)) * 257).astype(np.uint16)

    shift = np.array([dx, dy])
    direct = extract_centres(render(np.zeros(2)), method)
    shifted = xy(extract_centres(render(shift), method))
    moved = xy(direct) + shift
    margin = 40  # beyond the reach of the reflected border
    inside = np.all((shifted > margin) & (shifted < np.array(shape[::-1]) - 1 - margin), axis=1)
    assert inside.sum() > 20
    # Points slide along the line with a sub-pixel shift: compare offsets along the normal.
    _, nearest = cKDTree(moved).query(shifted[inside])
    normal = np.stack([direct.nx, direct.ny], axis=1)[nearest]
    across = np.abs(np.sum((shifted[inside] - moved[nearest]) * normal, axis=1))
    assert np.mean(across <= 0.03) >= 0.98  # sampling of a 5 px stripe: ~0.02 px


@settings(max_examples=200, deadline=None)
@given(st.integers(1, 400), st.integers(1, 5))
def test_every_from_both_ends_takes_the_same_points_whichever_way_a_chain_runs(size, step):
    """The widths and the body test read a subset of each chain: it must not depend on the
    chain's direction (a flipped frame's chains run the other way), hold both ends, and leave
    no run of more than `step` − 1 points out but where the halves meet (2·`step` − 2)."""
    taken = every_from_both_ends(size, step)
    assert np.array_equal(np.sort(size - 1 - taken), taken)
    assert taken[0] == 0 and taken[-1] == size - 1
    gaps = np.diff(taken)
    assert np.all(gaps <= 2 * step - 1) and np.count_nonzero(gaps > step) <= 1
