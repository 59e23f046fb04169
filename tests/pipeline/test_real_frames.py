"""Issue-15 bars on real laser frames (real_frames/PROVENANCE.md): the laser line, not edges.

Adaptive centres: ≥ 95 % of the medial axis covered (a centre within 2.5 px) and ≥ 95 % of
the centres on the line (within 3 px of a laser pixel). Where the method does not reach a bar
yet the test is an expected failure (strict), its reason the figure measured when the frames
were added.
"""

from __future__ import annotations

import functools

import cv2
import numpy as np
import pytest

from pipeline import extract_centres
from pipeline.imaging import laser_grey
from tests.pipeline.bars import bar_params
from tests.pipeline.real_frame_truth import (
    COLOUR_FRAMES,
    COLOUR_WIDTHS_PX,
    REAL_FRAME_NAMES,
    RealScore,
    load_real_frame,
    score_real_frame,
)

BAR_PCT = 95.0
NOT_YET = {
    ("charuco-red", "on-line"): "4.9 %: the board's white grid lines and print; grey hides the red",
    (
        "charuco-red",
        "coverage",
    ): "15.6 %: the red line is dim in grey over the black squares (was 22.5 %)",
    ("charuco-webcam", "on-line"): "4.1 %: the board's white grid lines and print, as charuco-red",
    ("charuco-webcam", "coverage"): "15.8 %: in grey the 2 px red line hardly stands out",
    (
        "charuco-dim",
        "on-line",
    ): "47.0 %: the grid lines crossing the line join it into one line (`joined_lines`) and, "
    "as strong in grey (C 16-25) as its stretches on white paper (18-21), are kept beside it",
    ("charuco-dim", "coverage"): "90.7 %: in grey the line fades on the white paper",
}


COLOUR_NOT_YET = {
    (
        "charuco-webcam",
        "coverage",
    ): "88.9 %: below the board (rows 432-477) the line fades to 5-20 levels of red excess; "
    "its ridge response V passes RIDGE_THRESHOLD at half of it, in pieces of 12-18 px, under "
    "MIN_COMPONENT_AREA_PX, so the stripe mask drops it (Steger 88.2 %)",
}


@functools.cache
def adaptive_score(name: str) -> RealScore:
    frame = load_real_frame(name)
    centres = extract_centres(frame.image, "adaptive")
    return score_real_frame(frame, centres.x, centres.y)


@pytest.mark.parametrize(
    ("metric", "name"), bar_params(REAL_FRAME_NAMES, ("coverage", "on-line"), NOT_YET)
)
def test_adaptive_meets_the_bar(metric: str, name: str) -> None:
    score = adaptive_score(name)
    value = score.coverage_pct if metric == "coverage" else score.on_line_pct
    assert value >= BAR_PCT, score


@functools.cache
def colour_score(name: str) -> RealScore:
    frame = load_real_frame(name)
    assert frame.colour is not None
    width_min, width_max = COLOUR_WIDTHS_PX[name]
    grey = laser_grey(frame.colour, COLOUR_FRAMES[name])
    centres = extract_centres(grey, "adaptive", width_min=width_min, width_max=width_max)
    return score_real_frame(frame, centres.x, centres.y)


@pytest.mark.parametrize(
    ("metric", "name"), bar_params(COLOUR_FRAMES, ("coverage", "on-line"), COLOUR_NOT_YET)
)
def test_adaptive_on_the_laser_colour_meets_the_bar(metric: str, name: str) -> None:
    """Colour frames taken by their laser's colour (`laser_grey`), not a grey conversion, at
    the width range configured for them (`COLOUR_WIDTHS_PX`)."""
    score = colour_score(name)
    value = score.coverage_pct if metric == "coverage" else score.on_line_pct
    assert value >= BAR_PCT, score


@pytest.mark.parametrize("name", REAL_FRAME_NAMES)
def test_truth_lies_on_a_bright_line(name: str) -> None:
    frame = load_real_frame(name)
    assert frame.image.dtype == np.uint8 and frame.laser_mask.shape == frame.image.shape
    rows, cols = frame.image.shape
    c, r = np.rint(frame.medial_xy).astype(int).T
    assert ((c >= 0) & (c < cols) & (r >= 0) & (r < rows)).all()
    assert frame.laser_mask[r, c].mean() > 0.99
    # The laser is brighter than a ring 4–10 px around its pixels.
    near = cv2.dilate(frame.laser_mask.astype(np.uint8), np.ones((21, 21))) > 0
    close = cv2.dilate(frame.laser_mask.astype(np.uint8), np.ones((9, 9))) > 0
    ring = near & ~close
    assert frame.image[frame.laser_mask].mean() > frame.image[ring].mean() + 10


def test_scores_of_the_medial_axis_itself_and_of_points_beside_it() -> None:
    frame = load_real_frame("weld-9")
    x, y = frame.medial_xy.T
    exact = score_real_frame(frame, x, y)
    assert exact.coverage_pct == 100 and exact.on_line_pct == 100
    beside = score_real_frame(frame, x, y - 20)
    assert beside.coverage_pct == 0 and beside.on_line_pct == 0
