"""One ordered trace of a fused profile: what a profile file, a CAD drawing, a report plot
and the 3-D view draw as the wheel's outline.

A fused profile pools every frame of both sensors (`fusion.fuse_profile`); their points
interleave along x with frame-to-frame offsets of 0.1–0.4 mm, so a line drawn through them
in their order zigzags between frames. The outline is the pooled points' medians in steps of
OUTLINE_STEP_MM along the profile: the back face bottom-up in steps of z, then the rest in
steps of x, where a run of steps steeper than STEEP_SLOPE (the flange's back, the flank, the
rim face) is walked in steps of z from the end nearest the outline so far. A handheld gauge
samples its contour every 0.25–1 mm (docs/formats.md), so the outline is a gauge-like
trace.
"""

from __future__ import annotations

import numpy as np

from pipeline.imaging import GEOMETRY_FLOAT
from pipeline.profile.fusion import BACK_FACE_BAND_MM, BACK_FACE_Z_MM

OUTLINE_STEP_MM = 0.25
"""Step of the outline along x (along z on the faces) [mm]: a MiniProf's sampling."""
STEEP_MAD_MM = 1.0
"""An x step whose points' z lie further than this from their median (median absolute
deviation) holds a steep part of the profile (a face): a 0.25 mm step of the 70° flank
spans 0.7 mm of z, so its MAD is about 0.2 mm; a step of the rim face holds tens of mm."""
STEEP_SLOPE = 2.0
"""A step where the steps' medians rise more than 2 mm per mm of x (63°) is walked along z:
in x steps a 0.25 mm step of the 70° flank would be 0.7 mm long, of the flange's back near
the back face 1.5–2 mm."""
RIM_FACE_MIN_DROP_MM = 10.0
RIM_FACE_MARGIN_MM = 0.5
"""A steep run spanning more than 10 mm of z and reaching 10 mm below the datum is the rim
face (the flank stands above z = 0); the wheel ends there, so outline points more than 0.5 mm
beyond its median x are dropped: on the field demo a stray stripe crossed the face and ran
on to x = 138.5 mm, and a gauge file ending there read upside down (its lowest point no
longer at the trace's x end)."""
OUTLINE_GAP_MM = 3.0
"""Consecutive outline points further apart than this start a new piece (a part of the
profile no sensor saw; the report plot's gap, `backend.services.report_plot.GAP_MM`)."""


def _group_medians(groups: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Median of `values` in each group of `groups` (non-negative run ids 0..G−1, each
    present), shape (G,)."""
    order = np.lexsort((values, groups))
    counts = np.bincount(groups)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    low = values[order[starts + (counts - 1) // 2]]
    high = values[order[starts + counts // 2]]
    return (low + high) / 2


def _steps(key: np.ndarray) -> np.ndarray:
    """Index 0..S−1 of each point's OUTLINE_STEP_MM step of `key`, in increasing `key`."""
    return np.unique(np.floor(key / OUTLINE_STEP_MM).astype(np.int64), return_inverse=True)[1]


def _step_medians(key: np.ndarray, x: np.ndarray, z: np.ndarray) -> np.ndarray:
    """(median x, median z) of the points in each OUTLINE_STEP_MM step of `key`, in
    increasing `key`; shape (S, 2)."""
    if key.size == 0:
        return np.zeros((0, 2), GEOMETRY_FLOAT)
    groups = _steps(key)
    return np.column_stack([_group_medians(groups, x), _group_medians(groups, z)])


def _steep_steps(x: np.ndarray, z: np.ndarray, groups: np.ndarray) -> np.ndarray:
    """Which x steps (`groups`) hold a steep part: their z spread (STEEP_MAD_MM) or the
    slope of the steps' medians two steps either side (STEEP_SLOPE); a step of fewer than
    3 points takes the flag of the step before it (the first steps: of the first step of 3
    or more)."""
    counts = np.bincount(groups)
    mx, mz = _group_medians(groups, x), _group_medians(groups, z)
    spread = _group_medians(groups, np.abs(z - mz[groups]))
    ahead = np.minimum(np.arange(counts.size) + 2, counts.size - 1)
    behind = np.maximum(np.arange(counts.size) - 2, 0)
    run = mx[ahead] - mx[behind]
    rise = np.abs(mz[ahead] - mz[behind])
    steep = (spread > STEEP_MAD_MM) | (rise > STEEP_SLOPE * np.where(run > 0, run, np.inf))
    full = np.flatnonzero(counts >= 3)
    for i in np.flatnonzero(counts < 3):
        steep[i] = steep[i - 1] if i > 0 else (steep[full[0]] if full.size else steep[i])
    return steep


def _walk(x: np.ndarray, z: np.ndarray) -> list[np.ndarray]:
    """The non-face points' trace: x steps, runs of steep steps walked along z."""
    groups = _steps(x)
    steep = _steep_steps(x, z, groups)
    runs = np.split(np.arange(steep.size), np.flatnonzero(np.diff(steep.astype(np.int8))) + 1)
    trace: list[np.ndarray] = []
    for run in runs:
        members = np.isin(groups, run)
        if steep[run[0]]:
            walked = _step_medians(z[members], x[members], z[members])
            if trace and abs(walked[-1, 1] - trace[-1][-1, 1]) < abs(
                walked[0, 1] - trace[-1][-1, 1]
            ):
                walked = walked[::-1]
            trace.append(walked)
        else:
            trace.append(_step_medians(x[members], x[members], z[members]))
    return trace


def _is_rim_face(run: np.ndarray) -> bool:
    """A run walked along z (`_walk`) that falls RIM_FACE_MIN_DROP_MM below the tread datum."""
    return (
        len(run) > 1
        and bool(run[:, 1].min() < -RIM_FACE_MIN_DROP_MM)
        and bool(np.ptp(run[:, 1]) > RIM_FACE_MIN_DROP_MM)
    )


def profile_outline(x_mm: np.ndarray, z_mm: np.ndarray) -> list[np.ndarray]:
    """The outline of a fused profile as pieces of one ordered trace.

    Parameters
    ----------
    x_mm, z_mm : ndarray of shape (K,)
        Fused profile points in the profile frame, any order [mm]; non-finite ones ignored.

    Returns
    -------
    list of ndarray of shape (S, 2), float64
        (x, z) [mm] along the profile from the back face's bottom to the rim face, one
        array per piece (a new piece after a gap of more than OUTLINE_GAP_MM); empty for
        no points.
    """
    x, z = np.asarray(x_mm, GEOMETRY_FLOAT), np.asarray(z_mm, GEOMETRY_FLOAT)
    finite = np.isfinite(x) & np.isfinite(z)
    x, z = x[finite], z[finite]
    on_face = (np.abs(x) < BACK_FACE_BAND_MM) & (z < BACK_FACE_Z_MM[1])
    trace = [_step_medians(z[on_face], x[on_face], z[on_face])]
    if np.any(~on_face):
        walked = _walk(x[~on_face], z[~on_face])
        faces = [run for run in walked if _is_rim_face(run)]
        if faces:  # the wheel ends at its rim face: what lies beyond it is another part
            within = x <= float(np.median(faces[-1][:, 0])) + RIM_FACE_MARGIN_MM
            walked = _walk(x[~on_face & within], z[~on_face & within])
        trace += walked
    points = np.concatenate(trace)
    if len(points) == 0:
        return []
    jumps = np.hypot(*np.diff(points, axis=0).T) > OUTLINE_GAP_MM
    return np.split(points, np.flatnonzero(jumps) + 1)


def outline_points(x_mm: np.ndarray, z_mm: np.ndarray) -> np.ndarray:
    """`profile_outline`'s pieces in one array of shape (S, 2) [mm], a NaN row between
    pieces (no row for no points)."""
    pieces = profile_outline(x_mm, z_mm)
    gap = np.full((1, 2), np.nan)
    joined = [part for piece in pieces for part in (gap, piece)][1:]
    return np.concatenate(joined) if joined else np.zeros((0, 2), GEOMETRY_FLOAT)
