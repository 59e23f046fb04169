"""The outline of a fused profile (pipeline/profile/outline.py): frames pooled in any order
give one trace along the profile, on the wheel, without the zigzag between frames."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from scipy.spatial import cKDTree

from pipeline.profile.exchange import handheld_parameters, profile_whl_text, read_profile_text
from pipeline.profile.flange import curve_flange_parameters
from pipeline.profile.outline import OUTLINE_GAP_MM, outline_points, profile_outline
from tests.pipeline.test_profile_exchange import contour_samples

FACE_BOTTOM_MM = -35.0


def wheel_contour(step_mm: float = 0.01) -> tuple[np.ndarray, np.ndarray]:
    """LMA from the back face's bottom over the flange and tread down the rim face [mm]."""
    x, z = contour_samples("LMA", step_mm)
    back = np.arange(FACE_BOTTOM_MM, z[0], step_mm)
    field = np.arange(z[-1], FACE_BOTTOM_MM, -step_mm)
    return (
        np.concatenate([np.zeros(back.size), x, np.full(field.size, x[-1])]),
        np.concatenate([back, z, field]),
    )


def pooled_frames(offsets_mm: np.ndarray, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """One sampling of the contour per frame, every 0.1 mm of arc from a random phase, each
    frame shifted by its (dx, dz) offset, with 0.03 mm noise; all frames shuffled."""
    rng = np.random.default_rng(seed)
    x, z = wheel_contour()
    arc = np.concatenate([[0], np.cumsum(np.hypot(np.diff(x), np.diff(z)))])
    xs, zs = [], []
    for dx, dz in offsets_mm:
        t = np.arange(rng.uniform(0, 0.1), arc[-1], 0.1)
        xs.append(np.interp(t, arc, x) + dx + rng.normal(0, 0.03, t.size))
        zs.append(np.interp(t, arc, z) + dz + rng.normal(0, 0.03, t.size))
    order = rng.permutation(sum(a.size for a in xs))
    return np.concatenate(xs)[order], np.concatenate(zs)[order]


@settings(max_examples=12, deadline=None)
@given(
    offsets=st.lists(
        st.tuples(st.floats(-0.15, 0.15), st.floats(-0.15, 0.15)), min_size=1, max_size=6
    ),
    seed=st.integers(0, 2**16),
)
# a step of 1–2 points left of the back face above it (a frame 0.14 mm towards −x) came
# first, on its own, and split the trace 4 mm from both neighbours
@example(offsets=[(0.0, 0.0), (0.0, 0.0), (-0.140625, 0.0), (0.125, 0.0)], seed=102)
def test_pooled_frames_give_one_trace_on_the_wheel_in_order(offsets, seed) -> None:
    x, z = pooled_frames(np.array(offsets), seed)
    pieces = profile_outline(x, z)
    assert len(pieces) == 1, [len(p) for p in pieces]
    trace = pieces[0]
    truth = np.column_stack(wheel_contour())
    distance, nearest = cKDTree(truth).query(trace)
    largest = max(np.hypot(dx, dz) for dx, dz in offsets)
    assert distance.max() < largest + 0.15, distance.max()
    # along the profile: each point's place on the true contour never goes back by more than
    # a step (the walk down the rim face starts beside the tread's last step)
    assert np.diff(nearest).min() > -60, np.diff(nearest).min()  # 60 × 0.01 mm
    assert np.hypot(*np.diff(trace, axis=0).T).max() < 1.5
    true_length = np.hypot(*np.diff(truth, axis=0).T).sum()
    length = np.hypot(*np.diff(trace, axis=0).T).sum()
    assert abs(length / true_length - 1) < 0.12, (length, true_length)
    # the points joined in their given order zigzag: several times as long
    assert np.hypot(np.diff(x), np.diff(z)).sum() > 3 * true_length


def test_a_stray_piece_below_the_tread_leaves_the_tread_alone() -> None:
    """A straight stray 10–20 mm under the tread near the rim face (another part's stripe
    through the rim, as on the field demo's wheel) is outvoted in each step of x."""
    x, z = pooled_frames(np.zeros((3, 2)), seed=7)
    stray_x = np.linspace(124.0, 131.0, 60)
    x = np.concatenate([x, stray_x])
    z = np.concatenate([z, -20.0 + (stray_x - 124.0) * 1.3])
    trace = np.concatenate(profile_outline(x, z))
    tread = (trace[:, 0] > 40) & (trace[:, 0] < 132)
    truth = np.column_stack(wheel_contour())
    assert cKDTree(truth).query(trace[tread])[0].max() < 0.15


def test_the_outline_ends_at_the_rim_face_and_reads_back_as_the_gauge_would() -> None:
    """A stray running on beyond the rim face (the field demo's wheel: from the face's
    middle to x = 138.5 mm) is not the wheel: the outline stops at the face, so the file
    written from it reads back the right way up with the wheel's parameters."""
    x, z = pooled_frames(np.full((3, 2), 0.05), seed=11)
    tail_x = np.linspace(135.6, 138.5, 40)
    x, z = np.concatenate([x, tail_x]), np.concatenate([z, -6.3 + (tail_x - 135.6)])
    trace = np.concatenate(profile_outline(x, z))
    face_x = wheel_contour()[0][-1]
    assert trace[:, 0].max() < face_x + 0.7
    read = read_profile_text(profile_whl_text(trace[:, 0], trace[:, 1], []), suffix=".whl")
    assert not read.reversed and read.x_offset_mm == 0.0
    truth = curve_flange_parameters(*contour_samples("LMA", 0.01))
    found = handheld_parameters(read).parameters
    for key in ("flange_height_mm", "flange_thickness_mm", "qr_mm"):
        assert getattr(found, key) == pytest.approx(getattr(truth, key), abs=0.1), key


def test_a_gap_splits_the_outline_and_no_points_give_none() -> None:
    x, z = pooled_frames(np.zeros((2, 2)), seed=3)
    hidden = (x > 40) & (x < 50)
    pieces = profile_outline(x[~hidden], z[~hidden])
    assert len(pieces) == 2
    assert pieces[0][-1, 0] < 40.3 and pieces[1][0, 0] > 49.7
    joined = outline_points(x[~hidden], z[~hidden])
    assert np.isnan(joined).all(axis=1).sum() == 1
    assert np.hypot(*(pieces[1][0] - pieces[0][-1])) > OUTLINE_GAP_MM
    assert profile_outline(np.array([]), np.array([])) == []
    assert outline_points(np.array([np.nan]), np.array([1.0])).shape == (0, 2)
