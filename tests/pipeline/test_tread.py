"""Tread hollow, flange angle and rim width against profiles whose values are known."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.profile.reference import load_reference_profile
from pipeline.profile.tread import (
    TreadNotFoundError,
    flange_angle,
    hollow_surface,
    outline_tread_values,
    rim_width,
    tread_hollow,
    tread_parameters,
)
from pipeline.profile.wheelset import WheelCurve, outline_running_surface, running_surface
from pipeline.simulation.wheel import Wear, wheel_profile


def straight_flank_profile(angle_deg: float, step_mm: float = 0.05):
    """Flange top at (20, 28), a straight flank at `angle_deg` down to z = 0, a flat tread to
    x = 135 and a vertical field face down to z = −40 (points along the outline)."""
    slope = 1 / np.tan(np.radians(angle_deg))  # dx per mm of drop
    crest_x = np.arange(10.0, 20.0, step_mm)
    crest = np.column_stack([crest_x, 28 - 0.02 * (crest_x - 20) ** 2])
    z = np.arange(28.0, 0.0, -step_mm * np.sin(np.radians(angle_deg)))
    flank = np.column_stack([20 + slope * (28 - z), z])
    tread_x = np.arange(flank[-1, 0] + step_mm, 135.0, step_mm)
    tread = np.column_stack([tread_x, np.zeros_like(tread_x)])
    face_z = np.arange(-step_mm, -40.0, -step_mm)
    face = np.column_stack([np.full_like(face_z, 135.0), face_z])
    points = np.concatenate([crest, flank, tread, face])
    return points[:, 0], points[:, 1]


@pytest.mark.parametrize("angle_deg", [65.0, 70.0, 78.5])
def test_straight_flank_gives_its_angle(angle_deg):
    x, z = straight_flank_profile(angle_deg)
    assert flange_angle(x, z, 28.0) == pytest.approx(angle_deg, abs=1e-6)


def test_flank_with_a_gap_is_not_measured():
    x, z = straight_flank_profile(70.0)
    keep = (z < 13.0) | (z > 16.5) | (x < 20)
    with pytest.raises(TreadNotFoundError, match="no points from z = 1[23].* to 16.[5-9] mm"):
        flange_angle(x[keep], z[keep], 28.0)


@pytest.mark.parametrize("gap", [(14.0, 16.0), (20.0, 22.4), (1.0, 3.0)])
def test_a_flank_gap_up_to_its_bridge_keeps_the_angle(gap):
    """Gaps ≤ 2.5 mm in height (as Sd and qR bridge) leave a straight flank's angle exact."""
    x, z = straight_flank_profile(70.0)
    keep = (z < gap[0]) | (z > gap[1]) | (x < 20)
    assert flange_angle(x[keep], z[keep], 28.0) == pytest.approx(70.0, abs=1e-6)


def test_the_steepest_part_of_a_curved_flank_over_ten_millimetres():
    """A flank of two straight pieces (60° below z = 14 mm, 75° above): the steepest 10 mm
    window lies in the 75° piece (the ±1 mm smoothing of the kink adds < 0.02°); noise of
    0.02 mm moves it by < 0.2°."""
    z = np.arange(0.5, 28.0, 0.01)
    x = 20 + np.where(
        z > 14,
        (28 - z) / np.tan(np.radians(75)),
        14 / np.tan(np.radians(75)) + (14 - z) / np.tan(np.radians(60)),
    )
    assert flange_angle(x, z, 28.0) == pytest.approx(75.0, abs=0.02)  # the kink smoothed
    rng = np.random.default_rng(5)
    noisy = [flange_angle(x + rng.normal(0, 0.02, x.size), z, 28.0) for _ in range(5)]
    assert np.ptp(noisy) < 0.2 and abs(np.mean(noisy) - 75.0) < 0.1


def test_an_overhanging_flank_is_not_an_angle_past_90_degrees():
    """Points whose x rises with z on the flank (junk, not the wheel) give no angle ≥ 90°."""
    x, z = straight_flank_profile(70.0)
    stretch = (z >= 4.0) & (z <= 14.0) & (x > 20)
    x = np.where(stretch, 25.0 + 0.4 * (z - 4.0), x)  # dx/dz = +0.4: 111.8° if believed
    with pytest.raises(TreadNotFoundError, match="overhangs"):
        flange_angle(x, z, 28.0)


def test_flat_tread_has_no_hollow_and_a_dip_its_depth():
    x = np.arange(20.0, 130.0, 0.1)
    assert tread_hollow(WheelCurve(x, -0.05 * (x - 70))) == pytest.approx(0.0, abs=1e-12)
    dip = 0.8 * np.exp(-(((x - 90) / 8) ** 2))
    assert tread_hollow(WheelCurve(x, -0.05 * (x - 70) - dip)) == pytest.approx(0.8, abs=1e-3)


def test_hollow_needs_the_tread_from_60_to_120_mm():
    x = np.arange(20.0, 110.0, 0.1)
    with pytest.raises(TreadNotFoundError, match="the hollow needs 60–120 mm"):
        tread_hollow(WheelCurve(x, np.zeros_like(x)))


@pytest.mark.parametrize(("name", "new_hollow_mm"), [("LMA", 0.045), ("S1002", 0.117)])
def test_reference_profiles_hollow_and_simulated_wear_deepens_it(name, new_hollow_mm):
    reference = load_reference_profile(name)
    values = []
    for depth in (0.0, 0.5, 1.0):
        wheel = wheel_profile(reference, Wear(hollow_depth_mm=depth))
        values.append(outline_tread_values(wheel.x_mm, wheel.z_mm, wheel.truth.flange_height_mm))
    assert values[0]["tread_hollow_mm"] == pytest.approx(new_hollow_mm, abs=1e-3)
    hollows = [v["tread_hollow_mm"] for v in values]
    assert hollows[0] < hollows[1] < hollows[2]
    assert values[0]["rim_width_mm"] == pytest.approx(float(reference.x_mm[-1]))


def test_rim_width_where_the_field_face_is_seen_else_the_reason():
    x, z = straight_flank_profile(70.0)
    assert rim_width(x, z) == (pytest.approx(135.0), None)
    width, reason = rim_width(x[z > -5], z[z > -5])
    assert width is None and "no field-side face (0 points" in reason


def test_running_surface_of_noisy_points_follows_the_curve():
    rng = np.random.default_rng(3)
    x, z = straight_flank_profile(70.0, step_mm=0.02)
    curve_true = outline_running_surface(x, z)
    noisy = z + rng.normal(0.0, 0.015, z.size)
    curve = running_surface(x, noisy)
    tread = (curve.x_mm > 45) & (curve.x_mm < 125)
    truth = np.interp(curve.x_mm[tread], curve_true.x_mm, curve_true.z_mm)
    assert np.abs(curve.z_mm[tread] - truth).max() < 0.01


def test_tread_parameters_report_each_missing_value_with_its_reason():
    x, z = straight_flank_profile(70.0)
    keep = z > -5  # no field face
    curve = outline_running_surface(x[keep], z[keep])
    values = tread_parameters(x[keep], z[keep], curve, 28.0)
    assert values.tread_hollow_mm == pytest.approx(0.0, abs=1e-9)
    assert values.flange_angle_deg == pytest.approx(70.0, abs=1e-6)
    assert values.rim_width_mm is None and values.reason.startswith("rim width: ")


def test_batched_local_quadratics_equal_robust_polyfit_node_by_node():
    from pipeline.errors import PipelineError
    from pipeline.profile.flange import robust_polyfit
    from pipeline.profile.wheelset import local_quadratics

    rng = np.random.default_rng(11)
    x = np.sort(rng.uniform(20.0, 120.0, 3000))
    z = 0.002 * (x - 70) ** 2 + rng.normal(0.0, 0.01, x.size)
    z[rng.choice(x.size, 60, replace=False)] += rng.uniform(0.2, 1.0, 60)  # glints
    x[1500:1520] = x[1500]  # a run of points at one x
    grid = np.arange(21.0, 119.0, 0.1)
    half = np.where(grid < 40.0, 0.5, 2.0)
    values = local_quadratics(x, z, grid, half)
    lo, hi = np.searchsorted(x, grid - half), np.searchsorted(x, grid + half)
    for i in range(grid.size):
        t = x[lo[i] : hi[i]] - grid[i]
        expected = np.nan
        if t.size >= 5 and np.ptp(t) >= half[i]:
            try:
                expected = robust_polyfit(t, z[lo[i] : hi[i]], 2, "test")[0][2]
            except PipelineError:
                pass
        assert values[i] == pytest.approx(expected, abs=1e-9, nan_ok=True), grid[i]


def _wandering_points(name: str, depth_mm: float, seed: int, sigma_mm: float = 0.04):
    """A worn outline's points every 0.08 mm of arc, their z wandering by `sigma_mm` over
    about 0.5 mm (a field frame's texture and grain), and the outline's true hollow."""
    outline = wheel_profile(load_reference_profile(name), Wear(hollow_depth_mm=depth_mm))
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(outline.x_mm), np.diff(outline.z_mm)))])
    along = np.arange(0.0, arc[-1], 0.08)
    x, z = np.interp(along, arc, outline.x_mm), np.interp(along, arc, outline.z_mm)
    rng = np.random.default_rng(seed)
    taps = np.exp(-0.5 * (np.arange(-30, 31) * 0.08 / 0.5) ** 2)
    wander = np.convolve(rng.normal(0, 1, x.size), taps / np.sqrt((taps**2).sum()), "same")
    truth = outline_tread_values(outline.x_mm, outline.z_mm, outline.truth.flange_height_mm)
    return x, z + sigma_mm * wander, truth["tread_hollow_mm"]


@pytest.mark.parametrize("name", ["LMA", "S1002"])
def test_the_hollow_of_wandering_points_is_read_on_the_smoother_surface(name: str) -> None:
    """Over 12 draws of points wandering 0.04 mm about a hollow-worn outline, the ±1.5 mm
    surface's deepest point reads the hollow about 0.02 mm deep on average (the largest of a
    noisy curve); the ±5 mm `hollow_surface` has no such bias and no larger error."""
    smooth_errors, rough_errors = [], []
    for seed in range(12):
        x, z, truth = _wandering_points(name, 0.6, seed)
        rough_errors.append(tread_hollow(running_surface(x, z)) - truth)
        smooth_errors.append(tread_hollow(hollow_surface(x, z)) - truth)
    assert np.mean(rough_errors) > 0.01
    assert abs(np.mean(smooth_errors)) < 0.005
    assert np.mean(np.abs(smooth_errors)) < np.mean(np.abs(rough_errors))


@pytest.mark.parametrize("name", ["LMA", "S1002"])
def test_an_exact_outline_keeps_its_hollow_on_the_smoother_surface(name: str) -> None:
    x, z, truth = _wandering_points(name, 0.6, 0, sigma_mm=0.0)
    assert tread_hollow(hollow_surface(x, z)) == pytest.approx(truth, abs=0.01)
