"""Input validation of frames at the pipeline's entry points."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from pipeline.imaging import IMAGE_FLOAT, LASER_CHANNELS, laser_grey, to_float_image, validate_image


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


@settings(max_examples=60, deadline=None)
@given(
    scene=hnp.arrays(np.uint8, (6, 7), elements=st.integers(0, 200)),
    tint=hnp.arrays(np.int16, (6, 7, 3), elements=st.integers(-8, 8)),
    line=st.integers(1, 54),
    laser=st.sampled_from(LASER_CHANNELS),
)
def test_laser_grey_keeps_the_laser_and_drops_an_achromatic_scene(
    scene: np.ndarray, tint: np.ndarray, line: int, laser: str
) -> None:
    """A grey scene (channels within ±8 of each other) gives at most 16; laser light added to
    its own channel in one row comes out as that light, to within the same tint."""
    frame = np.clip(scene[..., None].astype(int) + tint, 0, 255)
    assert laser_grey(frame.astype(np.uint8), laser).max() <= 16
    own = LASER_CHANNELS.index(laser)
    frame[2, :, own] += line
    frame = np.clip(frame, 0, 255).astype(np.uint8)
    grey = laser_grey(frame, laser)
    assert grey.dtype == np.uint8 and grey.shape == scene.shape
    clipped = frame[2, :, own] == 255
    lit = grey[2][~clipped].astype(int)
    assert (np.abs(lit - line) <= 16).all()
    assert (grey[2][clipped] == 255).all()


def test_laser_grey_of_16_bit_frames_clips_at_16_bit_full_scale() -> None:
    frame = np.full((3, 3, 3), 1000, np.uint16)
    frame[1, :, 1] = 65535
    frame[2, :, 1] = 5000
    assert laser_grey(frame, "green")[:, 0].tolist() == [0, 65535, 4000]


@pytest.mark.parametrize(
    ("frame", "laser", "error", "match"),
    [
        (np.zeros((5, 5), np.uint8), "red", ValueError, r"\(M, N, 3\)"),
        (np.zeros((5, 5, 4), np.uint8), "red", ValueError, r"\(M, N, 3\)"),
        (np.zeros((5, 5, 3), np.float32), "red", TypeError, "uint8 or uint16"),
        (np.zeros((5, 5, 3), np.uint8), "infrared", ValueError, "laser must be one of"),
        ([[1, 2, 3]], "red", TypeError, "ndarray"),
    ],
)
def test_laser_grey_rejects_what_it_cannot_convert(
    frame: object, laser: str, error: type, match: str
) -> None:
    with pytest.raises(error, match=match):
        laser_grey(frame, laser)
