"""Glints beside a dim stripe fitted and subtracted (`extract_centres(glint_subtraction=True)`,
off by default; `pipeline.extraction.glints`): the stripe's centres beside them come back on
its line."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline import extract_centres
from pipeline.extraction.glints import fit_glint, merged
from tests.pipeline.test_spots import SHAPE, _bend, _frame, _spot

ROWS, COLS = np.mgrid[0 : SHAPE[0], 0 : SHAPE[1]].astype(np.float64)
GLINT_X = 110.0


def _beside(stripe_peak, offset_px, sigma_px, glint_peak):
    """A dim bent stripe (w 9 px) with a glint touching its straight part at x = 110."""
    stripe, truth = _bend(ROWS, COLS, width_px=9.0, peak=stripe_peak)
    glint = _spot(ROWS, COLS, GLINT_X, 60.0 + offset_px, sigma_px, glint_peak)
    return _frame(stripe + glint), truth


def _near_glint(centres, truth):
    """Share of the true line within ±15 px of the glint with a centre within 1 px, and the
    largest distance of the centres there from the line (row 60) [px]."""
    line = truth[(np.abs(truth[:, 0] - GLINT_X) < 15) & (truth[:, 1] == 60.0)]
    d = np.hypot(line[:, None, 0] - centres.x[None], line[:, None, 1] - centres.y[None])
    near = (np.abs(centres.x - GLINT_X) < 15) & (np.abs(centres.y - 60.0) < 5)
    return float((d.min(axis=1) <= 1.0).mean()), float(np.abs(centres.y[near] - 60.0).max())


@pytest.mark.parametrize(
    ("stripe_peak", "offset_px", "sigma_px", "glint_peak"),
    [(70, 8, 2.5, 220), (60, 7, 2.0, 250), (80, 9, 3.0, 200)],
)
def test_a_glint_touching_a_dim_stripe_is_subtracted_and_the_stripe_read_on_its_line(
    stripe_peak, offset_px, sigma_px, glint_peak
) -> None:
    image, truth = _beside(stripe_peak, offset_px, sigma_px, glint_peak)
    plain = extract_centres(image, width_min=5, width_max=21)
    covered, worst = _near_glint(plain, truth)
    assert covered < 0.9 and worst > 0.9  # without it the glint cuts and bends the stripe
    fixed = extract_centres(image, width_min=5, width_max=21, glint_subtraction=True)
    covered, worst = _near_glint(fixed, truth)
    assert covered == 1.0
    assert worst < 0.2


def test_a_frame_without_spots_is_extracted_once_and_unchanged() -> None:
    stripe, _ = _bend(ROWS, COLS, width_px=9.0, peak=150.0)
    image = _frame(stripe)
    plain = extract_centres(image, width_min=5, width_max=21)
    fixed = extract_centres(image, width_min=5, width_max=21, glint_subtraction=True)
    np.testing.assert_array_equal(plain.x, fixed.x)
    np.testing.assert_array_equal(plain.y, fixed.y)


def test_the_fit_reads_the_glint_not_the_stripe_beside_it() -> None:
    image, _ = _beside(70, 8, 2.5, 220)
    amplitude, x, y, sigma_px, _ = fit_glint(image, GLINT_X + 0.6, 67.4, 2.9, 255.0)
    # Fitted with the stripe's pixels, the spot would lean 4 px (its bound) towards it and
    # widen; trimmed, it is off by 0.2 px towards the stripe, whose tails the fitted
    # background partly takes up (27 against the frame's 12 grey levels).
    assert abs(x - GLINT_X) < 0.1 and abs(y - 68.0) < 0.25
    assert abs(sigma_px - 2.5) < 0.15
    assert abs(amplitude - 220) < 20


def test_tops_of_one_spot_merge() -> None:
    tops = np.array([[10.0, 10.0, 2.0], [11.0, 12.0, 2.0], [20.0, 10.0, 3.0]])
    np.testing.assert_array_equal(merged(tops), tops[[0, 2]])
