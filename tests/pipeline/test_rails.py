"""Reference rails from their arcs and tangents, and the wheelset contact search on them."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from pipeline.profile.conicity import equivalent_conicity
from pipeline.profile.rails import GAUGE_DEPTH_MM, load_rail_profile, track_rails
from pipeline.profile.reference import load_reference_profile
from pipeline.profile.wheelset import (
    ContactError,
    WheelCurve,
    axle_conicity,
    rolling_radius_difference,
)
from pipeline.simulation.wheel import wheel_profile


def radius_along(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    du, dv = np.gradient(u), np.gradient(v)
    curvature = np.abs(du * np.gradient(dv) - dv * np.gradient(du)) / (du**2 + dv**2) ** 1.5
    return 1 / np.maximum(curvature, 1e-12)


def test_60e1_head_matches_its_drawing():
    rail = load_rail_profile("60E1")
    half = rail.u_mm >= 0
    u, v = rail.u_mm[half], rail.v_mm[half]
    radius = radius_along(u, v)
    # The R80 → R13 joint: the drawing dimensions it 52.053 mm across (found here to the
    # profile's 0.05 mm point spacing).
    joint = u[np.flatnonzero((radius[:-1] > 40) & (radius[1:] < 40))[0]]
    assert joint == pytest.approx(52.053 / 2, abs=0.06)
    # Head width 72 mm where R13 meets the 1:20 side, 14.30 mm below the crown.
    assert np.interp(-14.30, v[::-1], u[::-1]) == pytest.approx(36.0, abs=0.01)
    assert np.all(np.isclose(radius[(u > 1) & (u < 10)], 300, rtol=0.02))


def test_54e1_head_is_70_mm_wide_with_1_in_20_sides():
    rail = load_rail_profile("54E1")
    half = rail.u_mm >= 0
    u, v = rail.u_mm[half], rail.v_mm[half]
    slope = np.diff(u) / np.diff(v)
    side = np.flatnonzero(np.isclose(slope, -0.05, atol=1e-6))
    assert np.all(np.diff(side) == 1)  # one straight side, below the R13
    assert u[side[0]] == pytest.approx(35.0, abs=0.01)


@pytest.mark.parametrize("inclination", ["1:40", "1:20"])
def test_rails_sit_at_the_gauge_with_their_inclination(inclination):
    rails = track_rails("60E1", inclination=inclination, gauge_mm=1435.0)
    upper = rails.right_z_mm >= -GAUGE_DEPTH_MM
    assert rails.right_x_mm[upper].min() == pytest.approx(717.5, abs=1e-9)
    assert rails.left_x_mm[rails.left_z_mm >= -GAUGE_DEPTH_MM].max() == pytest.approx(-717.5)
    assert rails.right_z_mm.max() == 0.0
    # The head leans towards the track centre (its gauge side lower), so the highest point
    # moves off the head's middle towards the field side: to where the crown's slope equals
    # the tilt (on the R300 at 1:40: 300/40 = 7.5 mm; on the R80 at 1:20).
    crown_x = rails.right_x_mm[np.argmax(rails.right_z_mm)]
    tilt = {"1:40": 1 / 40, "1:20": 1 / 20}[inclination]
    crown_end = np.arcsin(10.228 / 300)
    along = 300 * tilt if tilt < crown_end else 220 * np.sin(crown_end) + 80 * np.sin(tilt)
    assert crown_x == pytest.approx(717.5 + 36.0 + along, abs=1.5)  # ± the gauge point's move


def test_bad_rail_arguments_are_rejected():
    with pytest.raises(ValueError, match="rail must be one of 60E1, 54E1"):
        load_rail_profile("49E1")
    with pytest.raises(ValueError, match="inclination must be one of"):
        track_rails(inclination="1:30")
    with pytest.raises(ValueError, match="gauge_mm must be in"):
        track_rails(gauge_mm=1000.0)


def cone(conicity: float) -> WheelCurve:
    x = np.linspace(20.0, 130.0, 1101)
    return WheelCurve(x, conicity * (70.0 - x))


@pytest.mark.parametrize(("conicity", "rail_radius_mm"), [(0.025, 300), (0.05, 300), (0.1, 80)])
def test_cone_wheelset_follows_klingel_with_the_roll_of_the_wheelset(conicity, rail_radius_mm):
    # Coned wheels γ on crowned rails: the roll φ = Δr/2e turns the contact on both rails,
    # so Δr = 2γy / (1 − γ(R_rail + r₀)/e) and Klingel's λ = γ/(1 − γ(R_rail + r₀)/e).
    # R_rail is the rail's radius where its slope (tilted 1:40) meets the cone's: the R300
    # crown up to a slope of 0.034 + 0.025, the R80 beyond.
    rails = track_rails()
    b2b, radius = 1360.0, 420.0
    result = axle_conicity(cone(conicity), cone(conicity), b2b, rails, radius_mm=radius)
    e = b2b / 2 + 77.0  # the contact: x ≈ 77 mm from each back face (rail crown)
    expected = conicity / (1 - conicity * (rail_radius_mm + radius) / e)
    assert result.conicity_3mm == pytest.approx(expected, rel=2e-3)
    assert all(v == pytest.approx(result.conicity_3mm, rel=2e-5) for v in result.curve_conicity)


def test_swapped_wheels_mirror_the_rolling_radius_difference():
    rails = track_rails()
    thin = wheel_profile(load_reference_profile("S1002"))
    top = int(np.argmax(thin.z_mm))
    end = top + int(np.flatnonzero(np.diff(thin.x_mm[top:]) <= 0)[0]) + 1
    new = WheelCurve(thin.x_mm[top:end], thin.z_mm[top:end])
    worn = WheelCurve(new.x_mm, new.z_mm - 0.6 * np.exp(-(((new.x_mm - 75) / 12) ** 2)))
    forward = rolling_radius_difference(new, worn, 1360.0, rails)
    backward = rolling_radius_difference(worn, new, 1360.0, rails)
    assert np.allclose(forward.delta_r_mm, -backward.delta_r_mm[::-1], atol=1e-6)
    same = rolling_radius_difference(new, new, 1360.0, rails)
    assert same.delta_r_mm[same.y_mm.size // 2] == pytest.approx(0.0, abs=1e-9)
    assert np.all(np.diff(same.delta_r_mm) >= -1e-9)


def test_wheels_that_miss_their_rails_are_an_error():
    from pipeline.profile.wheelset import ContactError

    short = WheelCurve(np.array([20.0, 40.0]), np.array([1.0, 0.0]))
    with pytest.raises(ContactError, match="does not reach over its rail"):
        rolling_radius_difference(short, short, 1360.0, track_rails())


def test_a_long_gap_in_the_flange_root_is_no_conicity_but_a_reason():
    """A straight bridge across the concave root lies above the wheel: the rail touches it
    and λₑ reads high (the demo pass's cause), so a gap over 8 mm is refused, a short one
    bridged."""
    rails = track_rails()
    thin = wheel_profile(load_reference_profile("S1002"))
    top = int(np.argmax(thin.z_mm))
    end = top + int(np.flatnonzero(np.diff(thin.x_mm[top:]) <= 0)[0]) + 1
    new = WheelCurve(thin.x_mm[top:end], thin.z_mm[top:end])
    root = new.x_mm[0] + np.array([16.0, 34.0])  # 18 mm of root, as in the demo's frames
    keep = (new.x_mm < root[0]) | (new.x_mm > root[1])
    gapped = WheelCurve(new.x_mm[keep], new.z_mm[keep])
    whole = axle_conicity(new, new, 1360.0, rails).conicity_3mm
    bridged = rolling_radius_difference(gapped, gapped, 1360.0, rails)
    assert abs(float(equivalent_conicity(bridged, 3.0)[0]) - whole) > 0.02  # the false contact
    from pipeline.profile.wheelset import ContactError

    with pytest.raises(ContactError) as refused:
        axle_conicity(gapped, new, 1360.0, rails)
    # The reason names each unseen stretch, from the back face and beyond the flange top.
    a, b = gapped.x_mm[gapped.x_mm < root[0]][-1], gapped.x_mm[gapped.x_mm > root[1]][0]
    assert str(refused.value) == (
        f"the left wheel's running surface shows no points from x = {a:.1f} to {b:.1f} mm "
        f"({a - new.x_mm[0]:.1f}–{b - new.x_mm[0]:.1f} mm beyond the flange top): a straight "
        "bridge over more than 8 mm can carry a false contact"
    )
    with pytest.raises(ContactError, match="left wheel's .*; the right wheel's running surface"):
        axle_conicity(gapped, gapped, 1360.0, rails)
    short = (new.x_mm < root[0]) | (new.x_mm > root[0] + 4.0)
    near = axle_conicity(WheelCurve(new.x_mm[short], new.z_mm[short]), new, 1360.0, rails)
    assert near.conicity_3mm == pytest.approx(whole, abs=0.01)


def test_contacts_on_a_sagging_bridge_refuse_only_the_amplitudes_that_reach_them():
    """A stretch without points under 8 mm is bridged, but no contact may fall on a bridge
    sagging over 0.02 mm: where none does (the flank, 2–8 mm beyond the top) every value
    stands; 24–30 mm beyond the top the rails touch it at |y| > 4.2 mm, so λₑ stands up to
    4 mm and the larger amplitudes are refused; 36–42 mm beyond the top the contacts of the
    3 mm swing fall on it (the straight bridge read 0.205 for 0.177), so λₑ(3 mm) is refused
    and the 1–2 mm amplitudes, clear of it, stand."""
    rails = track_rails()
    thin = wheel_profile(load_reference_profile("S1002"))
    top = int(np.argmax(thin.z_mm))
    end = top + int(np.flatnonzero(np.diff(thin.x_mm[top:]) <= 0)[0]) + 1
    new = WheelCurve(thin.x_mm[top:end], thin.z_mm[top:end])
    whole = axle_conicity(new, new, 1360.0, rails)
    assert whole.reason is None

    def gapped(lo: float, hi: float) -> WheelCurve:
        keep = (new.x_mm < new.x_mm[0] + lo) | (new.x_mm > new.x_mm[0] + hi)
        return WheelCurve(new.x_mm[keep], new.z_mm[keep])

    flank = axle_conicity(gapped(2, 8), gapped(2, 8), 1360.0, rails)
    assert flank.reason is None and flank.curve_conicity == whole.curve_conicity
    root = axle_conicity(gapped(24, 30), gapped(24, 30), 1360.0, rails)
    assert root.conicity_3mm == pytest.approx(whole.conicity_3mm, abs=1e-12)
    reached = np.array(root.curve_amplitudes_mm) > 4.0
    assert all(v is None for v, r in zip(root.curve_conicity, reached, strict=True) if r)
    assert all(
        v == pytest.approx(w, abs=1e-12)
        for v, w, r in zip(root.curve_conicity, whole.curve_conicity, reached, strict=True)
        if not r
    )
    assert root.reason.startswith("Δr(y) kept over y = -4.20 to +4.20 mm")
    assert "left wheel's over x = 39.0 to 45.0 mm (24.0–30.0 mm beyond the flange top)" in (
        root.reason
    )
    bridged = rolling_radius_difference(gapped(36, 42), gapped(36, 42), 1360.0, rails)
    assert float(equivalent_conicity(bridged, 3.0)[0]) - whole.conicity_3mm > 0.02
    tread = axle_conicity(gapped(36, 42), gapped(36, 42), 1360.0, rails)
    assert tread.conicity_3mm is None
    assert tread.curve_conicity[:3] == pytest.approx(whole.curve_conicity[:3], abs=1e-12)
    assert all(v is None for v in tread.curve_conicity[3:])
    assert tread.delta_r.y_mm[[0, -1]] == pytest.approx([-2.4, 2.4])


def test_a_minimum_at_the_wheel_curves_end_gives_no_invalid_values():
    """A tread seen only to x = 75 mm: at some shifts the smallest gap is the curve's last
    node, whose outer neighbour is off the curve (gap ∞); the parabola's refinement there
    multiplied ∞ by 0 ("invalid value encountered in multiply" on harsh passes)."""
    x = np.linspace(20.0, 75.0, 1101)
    short = WheelCurve(x, 0.05 * (70.0 - x))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        result = rolling_radius_difference(short, short, 1360.0, track_rails())
    assert np.all(np.isfinite(result.delta_r_mm))


def test_a_bump_on_the_tread_is_no_contact():
    """A glint's hook on the running surface (0.4 mm over about 1.5 mm, 36 mm beyond the
    flange top) stands above the tread around it, so a rail touches it first and Δr(y)
    sticks there: no λₑ comes from shifts whose contact falls on it, and the reason names
    it. The same hook 0.05 mm high is under the bump's 0.08 mm and changes nothing named."""
    rails = track_rails()
    thin = wheel_profile(load_reference_profile("S1002"))
    top = int(np.argmax(thin.z_mm))
    end = top + int(np.flatnonzero(np.diff(thin.x_mm[top:]) <= 0)[0]) + 1
    x, z = thin.x_mm[top:end], thin.z_mm[top:end]
    whole = axle_conicity(WheelCurve(x, z), WheelCurve(x, z), 1360.0, rails)
    at = x[0] + 36.0
    for height, named in ((0.4, True), (0.05, False)):
        hooked = WheelCurve(x, z + height * np.exp(-0.5 * ((x - at) / 0.5) ** 2))
        try:
            axle = axle_conicity(hooked, hooked, 1360.0, rails)
        except ContactError as exc:
            assert named and "bump" in str(exc) and f"x = {at:.1f}" in str(exc)
            continue
        assert ("bump" in (axle.reason or "")) == named
        if named:
            assert axle.conicity_3mm is None or axle.delta_r.y_mm.size < whole.delta_r.y_mm.size
