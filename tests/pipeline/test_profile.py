"""Fusion and datum from track-frame points of a known wheel (no images involved)."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.profile.flange import fit_flange_parameters
from pipeline.profile.fusion import (
    DatumError,
    clean_profile_points,
    fuse_profile,
    overlap_residual,
)
from pipeline.profile.reference import load_reference_profile
from pipeline.simulation.wheel import Wear, wheel_profile

PROFILE = wheel_profile(load_reference_profile("LMA"), Wear(0.5, 1.0, 0.3))


def _track_points(side: str, back_face_x_mm: float, rng=None, noise_mm: float = 0.0):
    """Inner: back face and flange (x < 25); outer: flange top onwards (x > 10). Z = −z."""
    sign = 1.0 if side == "right" else -1.0
    x, z = PROFILE.x_mm, PROFILE.z_mm
    points = np.column_stack([sign * (back_face_x_mm + x), np.zeros_like(x), -z])
    if rng is not None:
        points[:, [0, 2]] += rng.normal(0, noise_mm, (len(x), 2))
    return points[(x < 25) & (z > -39)], points[(x > 10) & (x < x.max())]


@pytest.mark.parametrize("side", ["left", "right"])
def test_exact_points_give_the_true_datum_and_parameters(side: str) -> None:
    inner, outer = _track_points(side, 677.25)
    profile = fuse_profile(inner, outer, side=side)
    sign = 1.0 if side == "right" else -1.0
    assert profile.back_face_track_x_mm == pytest.approx(sign * 677.25, abs=1e-6)
    assert profile.reference_track_z_mm == pytest.approx(0.0, abs=1e-3)
    assert profile.overlap_residual_mm is not None and profile.overlap_residual_mm < 0.01
    p = fit_flange_parameters(profile.x_mm, profile.z_mm)
    truth = PROFILE.truth
    assert p.flange_height_mm == pytest.approx(truth.flange_height_mm, abs=0.01)
    assert p.flange_thickness_mm == pytest.approx(truth.flange_thickness_mm, abs=0.01)
    assert p.flange_thickness_10_mm == pytest.approx(truth.flange_thickness_10_mm, abs=0.01)
    assert p.qr_mm == pytest.approx(truth.qr_mm, abs=0.02)


def test_profile_is_ordered_back_face_up_then_along_x() -> None:
    inner, outer = _track_points("right", 676.5)
    profile = fuse_profile(inner, outer, side="right")
    face = (np.abs(profile.x_mm) < 1.5) & (profile.z_mm < 2.0)
    n = np.count_nonzero(face)
    assert face[:n].all()
    assert np.all(np.diff(profile.z_mm[:n]) >= 0)
    assert np.all(np.diff(profile.x_mm[n:]) >= 0)


def test_stray_spike_from_one_sensor_is_dropped() -> None:
    inner, outer = _track_points("right", 676.5)
    top = PROFILE.x_mm[np.argmax(PROFILE.z_mm)]
    spike_z = -(PROFILE.truth.flange_height_mm + np.linspace(0.5, 5.0, 30))
    spike = np.column_stack([np.full(30, 676.5 + top), np.zeros(30), spike_z])
    profile = fuse_profile(np.concatenate([inner, spike]), outer, side="right")
    assert profile.rejected_points >= 30
    p = fit_flange_parameters(profile.x_mm, profile.z_mm)
    assert p.flange_height_mm == pytest.approx(PROFILE.truth.flange_height_mm, abs=0.01)


def test_noisy_points_stay_within_a_few_hundredths() -> None:
    inner, outer = _track_points("left", 676.0, np.random.default_rng(4), 0.03)
    profile = fuse_profile(inner, outer, side="left")
    p = fit_flange_parameters(profile.x_mm, profile.z_mm)
    assert p.flange_height_mm == pytest.approx(PROFILE.truth.flange_height_mm, abs=0.03)
    assert p.flange_thickness_mm == pytest.approx(PROFILE.truth.flange_thickness_mm, abs=0.03)
    assert 0.02 < profile.overlap_residual_mm < 0.08


def test_offset_sensor_shows_in_the_overlap_residual() -> None:
    inner, outer = _track_points("right", 676.5)
    outer = outer + np.array([0.0, 0.0, 0.2])
    profile = fuse_profile(inner, outer, side="right")
    assert profile.overlap_residual_mm == pytest.approx(0.2, abs=0.06)


def test_no_back_face_is_a_datum_error() -> None:
    _, outer = _track_points("right", 676.5)
    with pytest.raises(DatumError, match="back.face"):
        fuse_profile(outer[outer[:, 0] > 690], outer, side="right")


def test_unknown_side() -> None:
    inner, outer = _track_points("right", 676.5)
    with pytest.raises(ValueError, match="side must be 'left' or 'right', got 'middle'"):
        fuse_profile(inner, outer, side="middle")


def test_overlap_residual_of_a_line_by_hand() -> None:
    t = np.linspace(0, 10, 101)
    inner = np.column_stack([t, np.zeros_like(t)])
    outer = np.column_stack([t[20:80], np.full(60, 0.1)])
    residual, count = overlap_residual(inner, outer)
    assert residual == pytest.approx(0.1, abs=1e-9) and count == 60


def test_bump_seen_by_one_sensor_only_is_dropped() -> None:
    inner, outer = _track_points("right", 676.5)
    top = PROFILE.x_mm[np.argmax(PROFILE.z_mm)]
    x = inner[:, 0] - 676.5
    bump = np.abs(x - top + 0.5) < 1.0
    inner = inner.copy()
    inner[bump, 2] -= 0.25  # track Z down = profile z up
    profile = fuse_profile(inner, outer, side="right")
    assert profile.rejected_points >= np.count_nonzero(bump) // 2
    p = fit_flange_parameters(profile.x_mm, profile.z_mm)
    assert p.flange_height_mm == pytest.approx(PROFILE.truth.flange_height_mm, abs=0.02)


def test_smooth_disagreement_keeps_both_sensors() -> None:
    inner, outer = _track_points("right", 676.5)
    profile = fuse_profile(inner, outer + np.array([0.0, 0.0, 0.15]), side="right")
    assert profile.rejected_points == 0


def test_a_flange_top_in_short_pieces_is_kept_and_a_glint_above_it_is_not() -> None:
    """Under glare the dim top comes in 1.5 mm pieces (30 points each) 0.8 mm apart: they
    link into one piece of the profile; a compact glint 2.5 mm above the crest does not
    (one within the 1 mm link of the profile would: the consensus tests must drop it)."""
    x, z = PROFILE.x_mm, PROFILE.z_mm
    top = x[np.argmax(z)]
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(x), np.diff(z)))])
    near = np.abs(x - top) < 6.0
    pieces = near & (np.mod(arc - arc[near][0], 2.3) < 1.5)
    points = np.column_stack([676.5 + x, np.zeros_like(x), -z])
    inner = points[((x < top - 6.0) | pieces) & (z > -39)]
    outer = points[(x > top + 6.0) & (x < x.max())]
    rng = np.random.default_rng(3)
    glint = np.column_stack(
        [
            676.5 + top + rng.normal(0, 0.15, 30),
            np.zeros(30),
            -(PROFILE.truth.flange_height_mm + 2.5 + rng.normal(0, 0.15, 30)),
        ]
    )
    assert np.count_nonzero(pieces) > 100 and np.diff(np.flatnonzero(pieces)).max() > 1
    profile = fuse_profile(np.concatenate([inner, glint]), outer, side="right")
    assert profile.z_mm.max() < PROFILE.truth.flange_height_mm + 0.01
    p = fit_flange_parameters(profile.x_mm, profile.z_mm)
    assert p.flange_height_mm == pytest.approx(PROFILE.truth.flange_height_mm, abs=0.01)


def _flange_arc(count: int = 400) -> np.ndarray:
    """A smooth flange-like outline z(x) = 28 − (x − 16)²/20 sampled 0.05 mm apart [mm]."""
    x = 4.0 + 0.05 * np.arange(count)
    return np.column_stack([x, 28.0 - (x - 16.0) ** 2 / 20.0])


def test_a_piece_above_the_profile_is_dropped_and_one_below_kept() -> None:
    arc = _flange_arc()
    above = np.column_stack([np.linspace(15.0, 17.0, 45), np.linspace(30.0, 31.5, 45)])
    below = np.column_stack([np.linspace(15.0, 17.0, 45), np.linspace(26.0, 25.0, 45)])
    for piece, kept in ((above, False), (below, True)):
        xz = np.concatenate([arc, piece])
        sensor = np.concatenate([np.zeros(len(arc), np.int8), np.ones(len(piece), np.int8)])
        keep = clean_profile_points(xz, sensor)
        assert keep[: len(arc)].all()
        assert keep[len(arc) :].all() == kept and keep[len(arc) :].any() == kept


def test_a_spot_below_the_flange_top_does_not_lift_its_height() -> None:
    """A glint's points 5 mm below the top, within the top circle's ±4 mm, stay out of it."""
    profile = wheel_profile(load_reference_profile("LMA"))
    x, z = profile.x_mm, profile.z_mm
    clean = fit_flange_parameters(x, z).flange_height_mm
    top_x = x[np.argmax(z)]
    rng = np.random.default_rng(0)
    blob_x = top_x + 2.5 + rng.uniform(-0.8, 0.8, 60)
    blob_z = z.max() - 5.0 + rng.uniform(-0.6, 0.6, 60)
    order = np.argsort(np.concatenate([x, blob_x]), kind="stable")
    spotted = fit_flange_parameters(
        np.concatenate([x, blob_x])[order], np.concatenate([z, blob_z])[order]
    ).flange_height_mm
    assert spotted == pytest.approx(clean, abs=0.005)


def test_a_piece_fused_under_the_flange_top_does_not_unmake_its_crest() -> None:
    """A glare hook's 60 points 3.5–4.5 mm under the top, across its first ±2.5 mm window
    (as on harsh field pass 5, seed 2027, V001/2/right): the top is still a crest at its
    height (through every point of the window the robust quadratic turned concave up: "not
    a crest")."""
    outline = wheel_profile(load_reference_profile("S1002"))
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(outline.x_mm), np.diff(outline.z_mm)))])
    along = np.arange(0.0, arc[-1], 0.15)
    x, z = np.interp(along, arc, outline.x_mm), np.interp(along, arc, outline.z_mm)
    top_x = x[np.argmax(z)]
    hook_x = np.linspace(top_x - 2.0, top_x + 2.0, 60)
    hook_z = np.linspace(z.max() - 4.5, z.max() - 3.5, 60)
    order = np.argsort(np.concatenate([x, hook_x]), kind="stable")
    hooked = fit_flange_parameters(
        np.concatenate([x, hook_x])[order], np.concatenate([z, hook_z])[order]
    ).flange_height_mm
    assert hooked == pytest.approx(outline.truth.flange_height_mm, abs=0.005)


def test_a_spur_rising_beside_the_flange_top_does_not_set_its_height() -> None:
    """A Steger spur rising 3.8 mm above the top from the flange's back, 4 mm before the
    crest (the clean seed-7 pass's V001/1/right): Sh is the crest's (the band hung from the
    highest points held the spur alone, and the retry over all points read it 1.2 mm high)."""
    outline = wheel_profile(load_reference_profile("LMA"))
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(outline.x_mm), np.diff(outline.z_mm)))])
    along = np.arange(0.0, arc[-1], 0.15)  # the measured profiles' spacing
    x, z = np.interp(along, arc, outline.x_mm), np.interp(along, arc, outline.z_mm)
    clean = fit_flange_parameters(x, z).flange_height_mm
    root_x = x[np.argmax(z)] - 4.0
    spur_z = np.arange(
        np.interp(root_x, x[: np.argmax(z)], z[: np.argmax(z)]) + 0.3, z.max() + 3.8, 0.15
    )
    spur_x = root_x + 0.03 * np.arange(spur_z.size)
    order = np.argsort(np.concatenate([x, spur_x]), kind="stable")
    spurred = fit_flange_parameters(
        np.concatenate([x, spur_x])[order], np.concatenate([z, spur_z])[order]
    ).flange_height_mm
    assert spurred == pytest.approx(clean, abs=0.005)


def test_short_flank_pieces_continuing_the_profile_are_kept_and_pieces_beside_it_are_not() -> None:
    """Under glare a polished flank comes as its glare stretches alone: 3 mm pieces (23
    points) 2 mm apart from z = 3 to 22 mm, each under the 40 points of a piece, are kept
    as they continue the profile, and Sd is read from them; a 3 mm piece 2 mm inside the
    flank beside one of them (a ghost), a 2 mm streak across the flank in a gap and a
    compact blob 1 mm outside another are not."""
    x, z = PROFILE.x_mm, PROFILE.z_mm
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(x), np.diff(z)))])
    along = np.arange(0.0, arc[-1], 0.13)
    x, z = np.interp(along, arc, x), np.interp(along, arc, z)
    flank = (x > x[np.argmax(z)]) & (z > 3.0) & (z < 22.0)
    start = along[flank][0]
    stripe = ~flank | (np.mod(along - start, 5.0) < 3.0)
    first = flank & (along - start < 3.0)
    ghost = np.column_stack([x[first] - 2.0, z[first]])
    gap = flank & (np.abs(along - start - 4.0) < 0.07)
    normal = np.array([np.sin(np.radians(70.0)), np.cos(np.radians(70.0))])
    streak = np.column_stack([x[gap], z[gap]]) + np.outer(np.linspace(0.8, 2.8, 16), normal)
    blob_at = np.column_stack([x, z])[flank & (np.abs(along - start - 9.0) < 0.07)][0] + normal
    blob = blob_at + np.random.default_rng(5).normal(0.0, 0.15, (30, 2))
    xz = np.concatenate([np.column_stack([x, z])[stripe], ghost, streak, blob])
    sensor = np.ones(len(xz), np.int8)
    profile = np.zeros(len(xz), bool)
    profile[: np.count_nonzero(stripe)] = True
    pieces = np.diff(np.flatnonzero(stripe & flank)) > 1
    assert np.count_nonzero(pieces) >= 3 and np.count_nonzero(stripe & flank) < 40 * 5

    keep = clean_profile_points(xz, sensor)

    assert keep[profile].all() and not keep[~profile].any()
    p = fit_flange_parameters(xz[keep, 0], xz[keep, 1])
    assert p.flange_thickness_mm == pytest.approx(PROFILE.truth.flange_thickness_mm, abs=0.01)


def test_flank_pieces_continuing_each_other_far_from_the_top_and_tread_are_kept() -> None:
    """Short glare stretches: the flank from z = 5 to 17 mm comes as 1.5 mm pieces (under 40
    points each) 1 mm apart, 6 mm of stripe missing from the top's piece and from the
    tread's. No piece of 40 points is within reach, but together they hold more: they are
    kept and Sd is read from them. Two short pieces continuing each other alone (16 points)
    6 mm outside the flank are not."""
    x, z = PROFILE.x_mm, PROFILE.z_mm
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(x), np.diff(z)))])
    along = np.arange(0.0, arc[-1], 0.13)
    x, z = np.interp(along, arc, x), np.interp(along, arc, z)
    on_flank = x > x[np.argmax(z)]
    flank = on_flank & (z > 5.0) & (z < 17.0)
    start, stop = along[flank][0], along[flank][-1]
    missing = (
        on_flank
        & (((along > start - 6.0) & (along < start)) | (along > stop))
        & (along < stop + 6.0)
    )
    stretches = ~flank | (np.mod(along - start, 2.5) < 1.5)
    stripe = stretches & ~missing
    pieces = np.diff(np.flatnonzero(stripe & flank)) > 1
    assert np.count_nonzero(pieces) >= 5 and np.count_nonzero(stripe & flank) > 40
    first = flank & (along - start < 1.5)
    second = flank & (along - start >= 2.5) & (along - start < 4.0)
    pair = np.column_stack([x[first | second] + 6.0, z[first | second]])
    assert len(pair) < 40
    xz = np.concatenate([np.column_stack([x, z])[stripe], pair])
    sensor = np.ones(len(xz), np.int8)
    profile = np.zeros(len(xz), bool)
    profile[: np.count_nonzero(stripe)] = True

    keep = clean_profile_points(xz, sensor)

    assert keep[profile].all() and not keep[~profile].any()
    p = fit_flange_parameters(xz[keep, 0], xz[keep, 1])
    assert p.flange_thickness_mm == pytest.approx(PROFILE.truth.flange_thickness_mm, abs=0.01)


def test_a_streak_one_sensor_draws_above_the_others_tread_is_dropped_point_by_point() -> None:
    """A straight streak of the inner sensor's (another part's edge, 45 points) crossing the
    outer sensor's tread at x = 57 mm and rising to 2 mm above it by x = 60.5 mm is linked to
    the profile where it crosses, so no piece rule can drop it: its points more than 0.5 mm
    above the outer sensor's (within ±0.2 mm in x) are dropped, the rest and every point of
    the wheel are kept, and the overlap of the two sensors on the flange top loses none."""
    inner, outer = _track_points("right", 700.0)
    x, z = PROFILE.x_mm, PROFILE.z_mm
    sx = np.linspace(56.0, 60.5, 45)
    sz = np.interp(sx, x[x > 40], z[x > 40]) + np.linspace(-0.4, 2.0, 45)
    inner_xz = np.column_stack([inner[:, 0] - 700.0, -inner[:, 2]])
    outer_xz = np.column_stack([outer[:, 0] - 700.0, -outer[:, 2]])
    xz = np.concatenate([inner_xz, np.column_stack([sx, sz]), outer_xz])
    sensor = np.concatenate(
        [np.zeros(len(inner_xz) + len(sx), np.int8), np.ones(len(outer_xz), np.int8)]
    )
    streak = np.zeros(len(xz), bool)
    streak[len(inner_xz) : len(inner_xz) + len(sx)] = True
    above = np.zeros(len(xz), bool)
    above[streak] = sz - np.interp(sx, x[x > 40], z[x > 40]) > 0.6

    keep = clean_profile_points(xz, sensor)

    assert keep[~streak].all()
    assert not keep[above].any() and np.count_nonzero(above) >= 20


def test_points_the_flange_hides_from_their_camera_are_dropped() -> None:
    """The inner camera (inside the track, below the rail head) sees the flange's back and
    its crest; beyond the crest the flange hides the flank from it. Where the outer sensor
    lost the flank (z = 5–17 mm, so that none of its points lies below the piece for
    fusion's point rule), an inner-sensor piece 1.2 mm outside it (a reflection) is kept
    without the cameras and reads Sd over 1 mm off; with them it lies below the line
    from the inner camera through the crest and is dropped, none of the true points is, and
    the flank is honestly not measured."""
    x, z = PROFILE.x_mm, PROFILE.z_mm
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(x), np.diff(z)))])
    along = np.arange(0.0, arc[-1], 0.13)
    x, z = np.interp(along, arc, x), np.interp(along, arc, z)
    crest = int(np.argmax(z))
    flank = x > x[crest]
    inner = x <= x[crest] + 1.0  # the back face, the flange's back and its crest
    outer = (x >= x[crest] - 4.0) & ~(flank & (z > 5.0) & (z < 17.0))
    spur = flank & (z > 11.0) & (z < 16.0)
    xz = np.concatenate(
        [
            np.column_stack([x[inner], z[inner]]),
            np.column_stack([x[outer], z[outer]]),
            np.column_stack([x[spur] + 1.2, z[spur]]),
        ]
    )
    sensor = np.repeat(np.array([0, 1, 0], np.int8), [inner.sum(), outer.sum(), spur.sum()])
    true = np.arange(len(xz)) < inner.sum() + outer.sum()
    cameras = np.array([[-236.0, 171.0], [420.0, 171.0]])  # inner, outer (x, z) [mm]

    seen = clean_profile_points(xz, sensor, cameras)
    blind = clean_profile_points(xz, sensor)

    assert seen[true].all() and not seen[~true].any()
    assert blind[~true].all()
    wrong = fit_flange_parameters(xz[blind, 0], xz[blind, 1]).flange_thickness_mm
    assert wrong is not None and abs(wrong - PROFILE.truth.flange_thickness_mm) > 1.0
    honest = fit_flange_parameters(xz[seen, 0], xz[seen, 1])
    assert honest.flange_thickness_mm is None and honest.flange_thickness_10_mm is None
    assert honest.reason is not None and honest.reason.startswith("Sd: too few profile points")


def test_the_datum_is_the_cleaned_profiles_own_tread_height() -> None:
    """Nine points of another part's stripe 6 mm inside the wheel at x = 74–75 mm, beside an
    outer sensor whose tread is sampled every 0.18 mm, pull the first datum (taken from every
    point within ±5 mm of x = 70 mm) by 0.58 mm; fusion drops them, and the profile's z = 0 is
    then set at its own tread, so Sh and Sd read as without them (seed 2027's field pass 4,
    V002/1/left, a cluster of 9 points 5.9 mm inside: Sh +0.338 mm before)."""
    x, z = PROFILE.x_mm, PROFILE.z_mm

    def track(select: np.ndarray, step: int = 1) -> np.ndarray:
        at = np.flatnonzero(select)[::step]
        return np.column_stack([676.5 + x[at], np.zeros(at.size), -z[at]])

    px = np.linspace(74.0, 75.0, 9)
    pz = np.interp(px, x[x > 40], z[x > 40]) + 6.0
    piece = np.column_stack([676.5 + px, np.zeros_like(px), -pz])
    inner = np.concatenate([track((x < 25) & (z > -39)), piece])
    profile = fuse_profile(inner, track((x > 10) & (x < x.max()), 5), side="right")

    assert profile.rejected_points >= 9
    assert profile.reference_track_z_mm == pytest.approx(0.0, abs=2e-3)
    p = fit_flange_parameters(profile.x_mm, profile.z_mm)
    assert p.flange_height_mm == pytest.approx(PROFILE.truth.flange_height_mm, abs=0.01)
    assert p.flange_thickness_mm == pytest.approx(PROFILE.truth.flange_thickness_mm, abs=0.01)


def test_an_inner_streak_beyond_the_flank_is_dropped_and_the_outer_flank_kept() -> None:
    """An inner-sensor streak 4–6 mm beyond the flank at z = 14–20 mm, linked to the inner
    sensor's top (a field wheel in 3 frames: flange angle 10.3° steep), lies above the outer
    sensor's flank points there and is dropped; no outer flank point is judged by it."""
    x, z = PROFILE.x_mm, PROFILE.z_mm
    top = int(np.argmax(z))
    inner = np.flatnonzero(x < x[top] + 3.0)
    outer = np.flatnonzero((x > x[top] - 3.0) & (x < x.max()))
    flank = lambda height: np.interp(height, z[top:][::-1], x[top:][::-1])  # noqa: E731
    # from the inner's last top point out into the air, then 5 mm beyond the flank down to
    # z = 14 mm, 0.1 mm apart: one linked piece with the profile
    start = np.array([x[inner[-1]], z[inner[-1]]])
    bend = np.array([flank(20.0) + 5.0, 20.0])
    out = np.linspace(start, bend, int(np.hypot(*(bend - start)) / 0.1))
    heights = np.arange(20.0, 14.0, -0.1)
    down = np.column_stack([flank(heights) + 5.0, heights])
    streak = np.concatenate([out, down])
    air = streak[:, 0] > flank(streak[:, 1]) + 3.0
    xz = np.concatenate([np.column_stack([x, z])[inner], streak, np.column_stack([x, z])[outer]])
    sensor = np.repeat(np.array([0, 0, 1], np.int8), [inner.size, len(streak), outer.size])
    keep = clean_profile_points(xz, sensor)
    assert np.count_nonzero(air) >= 60
    assert not keep[inner.size : inner.size + len(streak)][air].any()
    assert keep[inner.size + len(streak) :].all()
