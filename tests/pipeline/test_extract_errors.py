"""Bad input to extract_centres gets a clear error naming the argument."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline import extract_centres

GOOD = np.full((40, 50), 12, np.uint8)


@pytest.mark.parametrize(
    ("image", "error", "match"),
    [
        (np.zeros((40, 50, 3), np.uint8), ValueError, "colour"),
        (np.zeros(50, np.uint8), ValueError, "2-D"),
        (np.zeros((0, 50), np.uint8), ValueError, "at least 3x3"),
        (np.full((40, 50), np.nan, np.float32), ValueError, "NaN"),
        (np.zeros((40, 50), bool), TypeError, "uint8 or uint16"),
        ([[1, 2, 3]], TypeError, "ndarray"),
    ],
)
def test_bad_frames(image, error, match) -> None:
    with pytest.raises(error, match=match):
        extract_centres(image)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"method": "hough"}, "method must be one of adaptive, steger, classic"),
        ({"width_min": 21, "width_max": 5}, "width_min must be ≤ width_max, got 21 > 5"),
        ({"width_min": 0}, "width_min must be a positive number of px, got 0"),
        ({"width_max": -3}, "width_max must be a positive number of px, got -3"),
        ({"width_min": float("nan")}, "width_min must be a positive number of px"),
        ({"width_min": 1}, "width_min must be ≥ 1.21 px"),
        ({"sigma": 3.0}, "sigma applies to the fixed-σ methods"),
        ({"method": "steger", "sigma": 0.1}, "sigma must be a number ≥ 0.7 px, got 0.1"),
        ({"method": "classic", "sigma": float("inf")}, "sigma must be a number"),
    ],
)
def test_bad_parameters(kwargs, match) -> None:
    with pytest.raises(ValueError, match=match):
        extract_centres(GOOD, **kwargs)


@pytest.mark.parametrize("method", ["adaptive", "steger", "classic"])
def test_frame_without_stripe_gives_empty_centres(method) -> None:
    centres = extract_centres(GOOD, method)
    assert len(centres) == 0
    assert centres.polylines == ()
    assert not centres.mask.any()
