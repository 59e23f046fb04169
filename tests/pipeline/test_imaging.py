"""Input validation of frames at the pipeline's entry points."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.imaging import IMAGE_FLOAT, to_float_image, validate_image


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
def test_grey_frames_become_float32_unchanged(dtype: type) -> None:
    image = np.arange(12, dtype=dtype).reshape(3, 4)
    out = to_float_image(image)
    assert out.dtype == IMAGE_FLOAT
    np.testing.assert_array_equal(out, image.astype(np.float32))


@pytest.mark.parametrize(
    ("image", "error", "match"),
    [
        (np.zeros((5, 5, 3), np.uint8), ValueError, "colour"),
        (np.zeros(10, np.uint8), ValueError, "2-D"),
        (np.zeros((0, 5), np.uint8), ValueError, "at least 3x3"),
        (np.full((5, 5), np.nan, np.float32), ValueError, "NaN"),
        (np.zeros((5, 5), bool), TypeError, "uint8 or uint16"),
        ([[1, 2], [3, 4]], TypeError, "ndarray"),
    ],
)
def test_bad_frames_get_a_clear_error(image: object, error: type, match: str) -> None:
    with pytest.raises(error, match=match):
        validate_image(image)
