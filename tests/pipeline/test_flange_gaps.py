"""Flange fits on profiles with gaps: a short flank gap is bridged and reported, a long one
or a flange top seen from one side only leaves the wheel not measured, with the reason."""

from __future__ import annotations

import re

import numpy as np
import pytest

from pipeline.profile.flange import (
    MAX_FLANK_GAP_MM,
    FlangeNotFoundError,
    curve_flange_parameters,
    fit_flange_parameters,
)
from pipeline.profile.reference import load_reference_profile


def _samples(name: str, step_mm: float = 0.05) -> tuple[np.ndarray, np.ndarray]:
    """The reference profile resampled every `step_mm` along its arc."""
    profile = load_reference_profile(name)
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(profile.x_mm), np.diff(profile.z_mm)))])
    at = np.arange(0.0, arc[-1], step_mm)
    return np.interp(at, arc, profile.x_mm), np.interp(at, arc, profile.z_mm)


def _without_flank(x, z, name, low_mm, high_mm):
    """Drop the flank points (tread side of the top) with low < z < high."""
    x_top = x[np.argmax(z)]
    keep = ~((x > x_top) & (z > low_mm) & (z < high_mm))
    return x[keep], z[keep]


@pytest.mark.parametrize("name", ["LMA", "S1002"])
@pytest.mark.parametrize(
    "low_mm, high_mm", [(11.2, 12.8), (9.3, 10.7), (10.9, 12.4), (9.0, 11.4), (11.5, 13.9)]
)
def test_a_short_flank_gap_is_bridged_and_reported(name, low_mm, high_mm) -> None:
    truth = curve_flange_parameters(*_samples(name, 0.01))
    x, z = _without_flank(*_samples(name), name, low_mm, high_mm)
    rng = np.random.default_rng(7)
    fitted = fit_flange_parameters(x + rng.normal(0, 0.01, x.size), z)
    assert fitted.flange_thickness_mm == pytest.approx(truth.flange_thickness_mm, abs=0.03)
    assert fitted.flange_thickness_10_mm == pytest.approx(truth.flange_thickness_10_mm, abs=0.03)
    assert high_mm - low_mm <= fitted.flank_gap_mm <= MAX_FLANK_GAP_MM


@pytest.mark.parametrize("name", ["LMA", "S1002"])
def test_a_whole_flank_reports_no_gap(name) -> None:
    assert fit_flange_parameters(*_samples(name)).flank_gap_mm == 0.0


@pytest.mark.parametrize("low_mm, high_mm", [(9.0, 13.0), (11.0, 25.0), (2.0, 20.0)])
def test_a_long_flank_gap_is_not_measured_and_says_so(low_mm, high_mm) -> None:
    x, z = _without_flank(*_samples("LMA"), "LMA", low_mm, high_mm)
    with pytest.raises(FlangeNotFoundError, match=r"flank near z = 1[02]\.00 mm .*a gap of"):
        fit_flange_parameters(x, z)


def test_a_flange_top_seen_on_one_side_only_is_not_measured() -> None:
    # the outer sensor's stripe lost from just past the crest down to the tread
    x, z = _samples("LMA")
    x_top = x[np.argmax(z)]
    keep = (x < x_top + 0.1) | (z < 2.0)
    with pytest.raises(FlangeNotFoundError, match="not seen on its flank side"):
        fit_flange_parameters(x[keep], z[keep])


@pytest.mark.parametrize("name", ["LMA", "S1002"])
def test_a_flank_lost_below_the_top_leaves_only_qr_not_measured(name) -> None:
    """The dim flange tip lost from 1 mm to 4.5 mm below the crest: Sh and Sd measured."""
    truth = curve_flange_parameters(*_samples(name, 0.01))
    sh = truth.flange_height_mm
    x, z = _without_flank(*_samples(name), name, sh - 4.5, sh - 1.0)
    fitted = fit_flange_parameters(x, z)
    assert fitted.qr_mm is None
    assert fitted.qr_reason is not None and fitted.qr_reason.startswith("qR: ")
    assert re.search(r"flank near z = 2\d\.\d\d mm", fitted.qr_reason)
    assert fitted.flange_height_mm == pytest.approx(sh, abs=0.02)
    assert fitted.flange_thickness_mm == pytest.approx(truth.flange_thickness_mm, abs=0.02)
    assert fitted.flank_gap_mm == 0.0
