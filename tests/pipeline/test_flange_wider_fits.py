"""The top and Sd fits widen where the points scatter and not where the profile bends
(`flange.widest_agreeing`, `TOP_WIDER_WINDOWS_MM`, `SD_WIDER_FITS`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pipeline.profile.exchange import read_profile_text
from pipeline.profile.flange import curve_flange_parameters, fit_flange_parameters, widest_agreeing
from pipeline.profile.reference import load_reference_profile
from pipeline.simulation.wheel import Wear, wheel_profile

HANDHELD = Path(__file__).with_name("handheld_files")


def test_the_widest_window_agreeing_with_every_narrower_one_is_chosen() -> None:
    assert widest_agreeing([1.0, 1.01, 1.015, 1.5], [0.01, 0.01, 0.01, 0.01]) == 2
    # points that scatter less than WIDER_MIN_ERROR_MM keep the narrowest fit
    assert widest_agreeing([1.0, 1.0001], [0.001, 0.001]) == 0
    assert widest_agreeing([1.0, 1.05], [0.01, 0.01]) == 0
    # once a window disagrees, no wider one is taken even if it agrees again
    assert widest_agreeing([1.0, 1.05, 1.0], [0.01, 0.01, 0.01]) == 0
    # a wider window must agree with the narrow ones' errors, not only its neighbour's
    assert widest_agreeing([1.0, 1.015, 1.03], [0.01, 0.01, 0.01]) == 1
    assert widest_agreeing([2.0], [np.inf]) == 0


def _sampled(outline, step_mm: float = 0.08):
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(outline.x_mm), np.diff(outline.z_mm)))])
    along = np.arange(0.0, arc[-1], step_mm)
    return along, np.interp(along, arc, outline.x_mm), np.interp(along, arc, outline.z_mm)


def _wander(along: np.ndarray, rng: np.random.Generator, sigma_mm: float, length_mm: float):
    """Correlated wander of the centres along the profile (texture, grain) [mm]."""
    white = rng.normal(0.0, 1.0, along.size)
    taps = np.exp(-0.5 * (np.arange(-40, 41) * (along[1] - along[0]) / length_mm) ** 2)
    smooth = np.convolve(white, taps / np.sqrt((taps**2).sum()), mode="same")
    return sigma_mm * smooth


@pytest.mark.parametrize("name", ["LMA", "S1002"])
def test_wandering_field_points_read_sh_and_sd_closer_to_the_truth(name: str) -> None:
    """Points wandering 0.05 mm about a worn outline over 0.5 mm (a field frame's texture):
    over 24 draws the widened fits' mean |error| is at least 5 % below the narrow windows' alone."""
    outline = wheel_profile(load_reference_profile(name), Wear(0.4, 1.2, 0.3))
    along, x, z = _sampled(outline)
    rng = np.random.default_rng(11)
    errors = {"wide": [], "narrow": []}
    import pipeline.profile.flange as flange

    for _ in range(24):
        nz = z + _wander(along, rng, 0.05, 0.5)
        nx = x + _wander(along, rng, 0.05, 0.5)
        wide = fit_flange_parameters(nx, nz)
        saved = flange.TOP_WIDER_WINDOWS_MM, flange.SD_WIDER_FITS
        flange.TOP_WIDER_WINDOWS_MM, flange.SD_WIDER_FITS = (), ()
        try:
            narrow = fit_flange_parameters(nx, nz)
        finally:
            flange.TOP_WIDER_WINDOWS_MM, flange.SD_WIDER_FITS = saved
        truth = outline.truth
        errors["wide"].append(
            abs(wide.flange_height_mm - truth.flange_height_mm)
            + abs(wide.flange_thickness_mm - truth.flange_thickness_mm)
        )
        errors["narrow"].append(
            abs(narrow.flange_height_mm - truth.flange_height_mm)
            + abs(narrow.flange_thickness_mm - truth.flange_thickness_mm)
        )
    assert np.mean(errors["wide"]) < 0.95 * np.mean(errors["narrow"]), errors


@pytest.mark.parametrize(("name", "wear"), [("LMA", Wear()), ("S1002", Wear(0.8, 2.0, 0.6))])
def test_exact_outlines_keep_their_parameters(name: str, wear: Wear) -> None:
    """Without scatter the wider windows change nothing that matters: Sh and Sd within
    0.01 mm of the outline's own."""
    outline = wheel_profile(load_reference_profile(name), wear)
    _, x, z = _sampled(outline, 0.15)
    fitted = fit_flange_parameters(x, z)
    assert fitted.flange_height_mm == pytest.approx(outline.truth.flange_height_mm, abs=0.01)
    assert fitted.flange_thickness_mm == pytest.approx(outline.truth.flange_thickness_mm, abs=0.01)


def test_a_real_s_shaped_flank_is_read_by_its_narrow_fit() -> None:
    """MiniProf Car7216: the worn flank bends in an S about z = 12 mm; the wider fits leave
    the narrow one's value (the cubic over ±5 mm reads 0.09 mm off it), so Sd stays within
    0.035 mm of the gauge's polyline."""
    profile = read_profile_text((HANDHELD / "Car7216_0001r.whl").read_text(), suffix=".whl")
    fitted = fit_flange_parameters(profile.x_mm, profile.z_mm)
    polyline = curve_flange_parameters(profile.x_mm, profile.z_mm)
    assert fitted.flange_thickness_mm == pytest.approx(polyline.flange_thickness_mm, abs=0.035)
