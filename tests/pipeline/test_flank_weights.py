"""The flank fits weight the centres by their line strength (`flange.FLANK_WEIGHT_STRENGTH`):
a dim frame's flank lying off beside a brighter frame's moves Sd less; equal strengths, or
none, fit as before."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.profile.flange import (
    FLANK_WEIGHT_STRENGTH,
    curve_flange_parameters,
    fit_flange_parameters,
    strength_weights,
)
from tests.pipeline.test_flange_gaps import _samples


def _two_frames(offset_mm: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The LMA outline twice: one frame on it, one with its flank (z 9–15 mm, tread side of
    the top) `offset_mm` outwards, and a frame index per point."""
    x, z = _samples("LMA")
    x_top = x[np.argmax(z)]
    flank = (x > x_top) & (z > 9.0) & (z < 15.0)
    return (
        np.concatenate([x, x + offset_mm * flank]),
        np.concatenate([z, z]),
        np.repeat([0, 1], x.size),
    )


def test_a_dim_frames_offset_flank_moves_sd_less_than_unweighted() -> None:
    truth = curve_flange_parameters(*_samples("LMA", 0.01)).flange_thickness_mm
    x, z, frame = _two_frames(0.02)
    unweighted = fit_flange_parameters(x, z).flange_thickness_mm - truth
    bright_dim = np.where(frame == 0, 60.0, 8.0)
    weighted = fit_flange_parameters(x, z, bright_dim).flange_thickness_mm - truth
    assert unweighted == pytest.approx(0.01, abs=0.003)
    assert abs(weighted) < 0.5 * abs(unweighted)


def test_equal_strengths_fit_as_unweighted() -> None:
    x, z, _ = _two_frames(0.02)
    plain = fit_flange_parameters(x, z)
    weighted = fit_flange_parameters(x, z, np.full(x.size, 15.0))
    assert weighted.flange_thickness_mm == pytest.approx(plain.flange_thickness_mm, abs=1e-9)
    assert weighted.flange_height_mm == plain.flange_height_mm


def test_strength_weights_level_off_above_the_floor() -> None:
    weights = strength_weights(np.array([0.0, 5.0, FLANK_WEIGHT_STRENGTH, 1000.0]))
    assert weights[0] == 0.0
    assert weights[1] == pytest.approx(5.0 / np.sqrt(1 + 0.25**2))
    assert weights[2] == pytest.approx(FLANK_WEIGHT_STRENGTH / np.sqrt(2))
    assert weights[3] == pytest.approx(FLANK_WEIGHT_STRENGTH, rel=1e-3)


def test_strength_of_the_wrong_shape_is_refused() -> None:
    x, z = _samples("LMA")
    with pytest.raises(ValueError, match="strength"):
        fit_flange_parameters(x, z, np.ones(3))
