"""Guided search across a gap between two kept chains: the stripe where the mask lost it.

Under a polished band the diffuse stripe falls to the background's grey and comes as a
dotted trace between glints (the field simulator's flange root and flank, docs/simulator.md);
its ridge response stays under the mask's threshold, so no candidate, kept or rejected,
lies over the gap, and the chains on either side end facing each other. Where two chain
ends face each other across such a gap, the path between them is known at both ends: a
cubic through both ends with their directions predicts it, and the stripe is looked for in
a narrow corridor around that prediction, at a contrast the mask does not ask for. The
brightest path through the corridor that starts on one end and finishes on the other
(dynamic programming, one pixel of offset per pixel of length) is refined by the matched
fit along its normal (`normal_fit.matched_offsets`) and each point tested as a line
(`line_test.is_line`), and the gap's points are kept only when they bridge it: the tested
points follow each other from one end to the other with no longer run of failures than
`MAX_MISS_PX`. A tracker from one end has nothing to hold it to the stripe; anchored at
both ends and asked to pass the line test nearly throughout, the path through texture or
across a real break of the stripe (a depth step, an occluded stretch) is refused.

Only the frame and the chains' centres are read, so the band path and the whole frame give
the same points.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from pipeline.extraction.line_test import SIDE_REACH_SIGMAS, is_line, line_profiles
from pipeline.extraction.normal_fit import matched_offsets
from pipeline.extraction.scalespace import bilinear_points
from pipeline.extraction.segmentation import END_TANGENT_POINTS, chain_ends
from pipeline.imaging import GEOMETRY_FLOAT

MIN_GAP_PX = 16.0
"""Shorter gaps are left to fusion, which bridges 2.5 mm of profile (about 16 px of flank on
the simulated outer frames): bridges of 4–16 px between pieces of one stripe added points
0.1–0.5 mm off the outline (pass 6, seed 2027) and no measured wheel."""
MAX_GAP_PX = 160.0
"""Longest gap searched [px]: the flank's polished band on the simulated outer frames, a
6 mm gap at about 6.5 px/mm, is 40 px, the dim root with its glare up to 150 px."""
FACING_COS = 0.5
"""Each end's outward direction lies within 60° of the line to the other end."""
CORRIDOR_FRACTION = 0.15
"""Half-width of the corridor around the predicted path, as a share of the gap's length:
the cubic through both ends cuts a corner of the stripe (the flange root) by up to about a
tenth of the gap."""
MIN_CORRIDOR_PX = 3.0
"""... at least this many px either side."""
ALONG_PX = 2
"""The corridor's grey is averaged over ±ALONG_PX px along the predicted path: the dotted
trace's dots are 3–6 px long."""
MAX_MISS_PX = 32
"""Longest run of path points that fail the line test inside an accepted bridge [px of
path]: beside a glint or the glare the line test fails on the stripe itself (a side brighter
than the line) for up to 25 px on the simulated outer frames (pass 5, V001/1/right: 25 px
between a glint and the flank's lower chain). Only the points that pass are
kept, so fusion sees the remaining holes (it bridges up to 2.5 mm, about 16 px of flank)."""
MIN_PASS_SHARE = 0.5
"""Least share of the path's points that pass the line test."""
TURN_POINTS = 4
"""A bridge's direction is compared over chords of this many kept points before and after
each point (about 8 px of stripe)."""
MAX_TURN_COS = math.cos(math.radians(40.0))
"""... and turns by at most 40° at every point: the flange root's corner turns by about 25°
over such chords on the simulated outer frames, while a path drawn off the dim trace by a
texture blob beside it comes back in a hook (pass 6, V002/1/right: 1.1 mm off the flank)."""
SCORE_CAP_C = 6.0
"""A path point's score is capped at this many c (15.3 grey levels in 8 bit): a glint
beside the trace, 100+ grey levels above its surroundings, would otherwise draw the path
through it."""
TURN_COST_C = 3.0
"""Score lost per px of offset change between path points, in c (7.7 grey levels in 8 bit):
the path follows the dim trace past a glint 12 px beside it (at 0.5 c it ran through the
glint, simulated outer frame pass 5, V001/1/right) and still drifts by the 10–20 px the
cubic cuts off the flange root's corner over a 150 px gap."""
CLEAR_PX = 6.0
"""A gap is searched only where no other kept chain's centre lies within this distance of
the predicted path [px]: there the stripe is found already (chains that overlap or continue
one another along it), and the gap is not one."""
MIN_HEIGHT_C = 2.0
"""A bridge point's line stands at least this many times the ridge response's structure
constant c above its brighter side (5.1 grey levels in 8 bit); the mask asks the ridge for
about 1.2 c of curvature-normalised strength, which a dotted trace does not keep along its
length."""
MATCHED_FACTOR = 2.0
"""The matched kernel's scale on bridge points, in units of the profile's s (√3σ/4): the
wider of `centres.KERNEL_FACTORS`, which weights the flanks where texture multiplies the
stripe."""
REFINE_ROUNDS = 2
"""Matched-fit rounds on a bridge point (each moves it by at most `normal_fit.MAX_MOVE_PX`):
the path's points lie within 0.5 px of the ridge."""


@dataclass(frozen=True, slots=True, eq=False)
class Bridges:
    """Centres found across gaps between chains; arrays (K,) float64.

    Attributes
    ----------
    x, y : ndarray
        Centres [px].
    nx, ny : ndarray
        Unit normals, turning smoothly along each bridge.
    sigma : ndarray
        The scale the bridge was searched at [px]: the mean σ of the two chains' ends.
    strength : ndarray
        σ²·(the profile's second derivative across the line at σ) [grey levels].
    chains : tuple of ndarray of int64
        Each bridge's points, ordered from one end to the other, indexing the arrays.
    gaps : int
        Gaps searched (pairs of facing ends).
    """

    x: np.ndarray
    y: np.ndarray
    nx: np.ndarray
    ny: np.ndarray
    sigma: np.ndarray
    strength: np.ndarray
    chains: tuple[np.ndarray, ...]
    gaps: int

    def __post_init__(self) -> None:
        for array in (self.x, self.y, self.nx, self.ny, self.sigma, self.strength, *self.chains):
            array.flags.writeable = False


def _ends(x, y, sigma, chains) -> np.ndarray:
    """(2·len(chains), 5) rows (x, y, tx, ty, σ) of each chain's two ends: x, y, tx, ty as
    `segmentation.chain_ends` gives them, σ the mean scale over the same END_TANGENT_POINTS
    centres."""
    k = [min(END_TANGENT_POINTS, chain.size) for chain in chains]
    scales = [(sigma[c[:n]].mean(), sigma[c[-n:]].mean()) for c, n in zip(chains, k, strict=True)]
    return np.column_stack([chain_ends(x, y, chains), np.ravel(scales)])


def _facing_pairs(ends: np.ndarray) -> list[tuple[int, int]]:
    """Pairs of ends of different chains that face each other across MIN_GAP_PX to
    MAX_GAP_PX, nearest first, each end in one pair at most."""
    gap = ends[None, :, :2] - ends[:, None, :2]  # from end i to end j
    length = np.hypot(gap[..., 0], gap[..., 1])
    safe = np.where(length > 0, length, 1.0)
    out_i = np.einsum("ijk,ik->ij", gap, ends[:, 2:4]) / safe
    chain = np.arange(len(ends)) // 2
    ok = (length >= MIN_GAP_PX) & (length <= MAX_GAP_PX) & (chain[:, None] != chain[None, :])
    ok &= (out_i >= FACING_COS) & (out_i.T >= FACING_COS)
    ok &= np.triu(np.ones_like(ok), 1).astype(bool)
    used: set[int] = set()
    pairs = []
    for flat in np.argsort(np.where(ok, length, np.inf), axis=None):
        i, j = divmod(int(flat), len(ends))
        if not ok[i, j]:
            break
        if i not in used and j not in used:
            pairs.append((i, j))
            used.update((i, j))
    return pairs


def _predicted(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Points (K, 2) about 1 px apart on the cubic Hermite curve from end `a` to end `b`
    (leaving a along its outward direction, arriving at b against b's), and unit normals."""
    length = math.hypot(b[0] - a[0], b[1] - a[1])
    s = np.linspace(0.0, 1.0, int(math.ceil(length)) + 1)[:, None]
    h00, h10 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s
    h01, h11 = -2 * s**3 + 3 * s**2, s**3 - s**2
    path = h00 * a[:2] + h10 * length * a[2:4] + h01 * b[:2] - h11 * length * b[2:4]
    tangent = np.gradient(path, axis=0)
    tangent /= np.maximum(np.hypot(tangent[:, 0], tangent[:, 1]), 1e-9)[:, None]
    return path, np.column_stack([-tangent[:, 1], tangent[:, 0]])


def _ridge_scores(image, path, normal, sigma, half_width) -> np.ndarray:
    """(K, 2·half_width + 1) score of the ridge at each path point and offset: the grey
    averaged ±ALONG_PX along the path, less the brighter of its levels ±d across
    (d = SIDE_REACH_SIGMAS·σ)."""
    offsets = np.arange(-half_width, half_width + 1, dtype=GEOMETRY_FLOAT)
    tangent = np.column_stack([normal[:, 1], -normal[:, 0]])
    reach = SIDE_REACH_SIGMAS * sigma
    reads = {}
    for shift in (-reach, 0.0, reach):
        total = np.zeros(len(path) * offsets.size)
        for along in range(-ALONG_PX, ALONG_PX + 1):
            at = path[:, None, :] + (offsets[None, :, None] + shift) * normal[:, None, :]
            at = at + along * tangent[:, None, :]
            total = total + bilinear_points(image, at[..., 0].ravel(), at[..., 1].ravel())
        reads[shift] = (total / (2 * ALONG_PX + 1)).reshape(len(path), offsets.size)
    return reads[0.0] - np.maximum(reads[-reach], reads[reach])


def _best_path(scores: np.ndarray, half_width: int, turn_cost: float) -> np.ndarray:
    """Offsets (K,) of the highest-scoring path from offset 0 at the first point to offset 0
    at the last, moving by at most one offset a step, each move costing `turn_cost`."""
    k, m = scores.shape
    total = np.full((k, m), -np.inf)
    came = np.zeros((k, m), np.int64)
    total[0, half_width] = scores[0, half_width]
    for i in range(1, k):
        prev = total[i - 1]
        stacked = np.stack([np.roll(prev, 1) - turn_cost, prev, np.roll(prev, -1) - turn_cost])
        stacked[0, 0] = stacked[2, -1] = -np.inf
        step = np.argmax(stacked, axis=0)
        total[i] = stacked[step, np.arange(m)] + scores[i]
        came[i] = np.arange(m) + step - 1
    offsets = np.zeros(k, np.int64)
    offsets[-1] = half_width
    for i in range(k - 1, 0, -1):
        offsets[i - 1] = came[i, offsets[i]]
    return offsets - half_width


def _longest_miss(passed: np.ndarray) -> int:
    """Longest run of False in `passed`."""
    runs = np.diff(np.flatnonzero(np.concatenate(([True], passed, [True])))) - 1
    return int(runs.max()) if runs.size else 0


def _bridge(image, a, b, others, *, width_min, c_grey):
    """The centres (x, y, nx, ny, strength), ordered from a to b, of the stripe across the
    gap between ends a and b, or None when the path does not bridge it or `others` (a
    cKDTree of the other chains' centres, or None) has a centre on the predicted path."""
    path, normal = _predicted(a, b)
    sigma = 0.5 * (a[4] + b[4])
    length = math.hypot(b[0] - a[0], b[1] - a[1])
    half_width = int(math.ceil(max(MIN_CORRIDOR_PX, CORRIDOR_FRACTION * length)))
    if others is not None:
        near, _ = others.query(path[1:-1], distance_upper_bound=CLEAR_PX)
        if np.isfinite(near).any():
            return None
    scores = np.minimum(_ridge_scores(image, path, normal, sigma, half_width), SCORE_CAP_C * c_grey)
    offsets = _best_path(scores, half_width, TURN_COST_C * c_grey)
    points = path + offsets[:, None] * normal
    inner = slice(1, len(points) - 1)  # the ends are the chains' own centres
    points = points[inner]
    if len(points) < 3:
        return None
    tangent = np.gradient(np.column_stack([points[:, 0], points[:, 1]]), axis=0)
    tangent = _smoothed(tangent)
    tangent /= np.maximum(np.hypot(tangent[:, 0], tangent[:, 1]), 1e-9)[:, None]
    nx, ny = -tangent[:, 1], tangent[:, 0]
    x, y = points[:, 0].copy(), points[:, 1].copy()
    s = np.full(x.size, max(math.sqrt(3) / 4 * sigma, 1.0))
    sig = np.full(x.size, sigma)
    for _ in range(REFINE_ROUNDS):
        t = matched_offsets(image, x, y, nx, ny, s, (MATCHED_FACTOR,))[0]
        t = np.where(np.isfinite(t), t, 0.0)
        x, y = x + t * nx, y + t * ny
    profiles = line_profiles(image, x, y, nx, ny, sig, width_min_px=width_min, c_grey=c_grey)
    passed = is_line(profiles) & (profiles[2] >= MIN_HEIGHT_C * c_grey)
    if _longest_miss(passed) > MAX_MISS_PX or passed.mean() < MIN_PASS_SHARE:
        return None
    if _turns_sharply(x[passed], y[passed]):
        return None
    strength = sigma**2 * _curvature_across(image, x, y, nx, ny, sigma)
    return x[passed], y[passed], nx[passed], ny[passed], strength[passed], sigma


def _turns_sharply(x: np.ndarray, y: np.ndarray) -> bool:
    """Whether the chords of TURN_POINTS points before and after any point meet at an angle
    whose cosine is below MAX_TURN_COS."""
    k = TURN_POINTS
    if x.size < 2 * k + 1:
        return False
    before = np.column_stack([x[k:-k] - x[: -2 * k], y[k:-k] - y[: -2 * k]])
    after = np.column_stack([x[2 * k :] - x[k:-k], y[2 * k :] - y[k:-k]])
    norms = np.hypot(before[:, 0], before[:, 1]) * np.hypot(after[:, 0], after[:, 1])
    cos = np.einsum("ij,ij->i", before, after) / np.maximum(norms, 1e-9)
    return bool((cos < MAX_TURN_COS).any())


def _smoothed(values: np.ndarray) -> np.ndarray:
    """(K, 2) values averaged over ±ALONG_PX neighbours (fewer at the ends)."""
    out = np.zeros_like(values)
    count = np.zeros(len(values))
    for shift in range(-ALONG_PX, ALONG_PX + 1):
        lo, hi = max(0, -shift), min(len(values), len(values) - shift)
        out[lo:hi] += values[lo + shift : hi + shift]
        count[lo:hi] += 1
    return out / count[:, None]


def _curvature_across(image, x, y, nx, ny, sigma) -> np.ndarray:
    """−d²/dn² [grey levels/px²] of the profile across each point, smoothed at σ: three
    reads σ apart of the grey averaged over ±σ along the normal (a box of the Gaussian's
    width)."""
    reads = []
    for t in (-sigma, 0.0, sigma):
        taps = np.linspace(-sigma, sigma, 5)
        total = sum(bilinear_points(image, x + (t + u) * nx, y + (t + u) * ny) for u in taps)
        reads.append(total / taps.size)
    return np.maximum((2 * reads[1] - reads[0] - reads[2]) / sigma**2, 0.0)


def bridge_gaps(
    image: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
    sigma: np.ndarray,
    chains: list[np.ndarray],
    *,
    width_min_px: float,
    c_grey: float,
) -> Bridges:
    """Centres of the stripe across gaps between chains whose ends face each other.

    Parameters
    ----------
    image : ndarray of shape (M, N), uint8, uint16 or float
        The frame [grey levels].
    x, y, sigma : ndarray of shape (K,)
        The kept centres [px] and the scales they were found at [px].
    chains : list of ndarray of int64
        The kept chains, each an ordered index array into x, y, sigma.
    width_min_px : float
        The narrowest stripe width expected [px] (the line test's shoulders).
    c_grey : float
        The ridge response's structure constant c [grey levels] (`ridges.RIDGE_C_FULL_SCALE`
        of full scale).

    Returns
    -------
    Bridges
        The bridges' centres, one chain per bridged gap (empty when none is bridged).

    Notes
    -----
    Ends of different chains are paired when each end's outward direction (over its last
    END_TANGENT_POINTS centres) lies within 60° of the line to the other and they lie MIN_GAP_PX
    to MAX_GAP_PX apart, nearest pairs first. The path is predicted by the cubic Hermite
    curve P(s) = h00·a + h10·L·t_a + h01·b − h11·L·t_b (L the gap, t the outward
    directions), sampled 1 px apart; offsets of up to ±max(MIN_CORRIDOR_PX,
    CORRIDOR_FRACTION·L) along its normal are scored by the grey there less the brighter
    of the levels ±2.18σ across, and the path of the highest total score from a to b,
    moving one px of offset per px at most, is kept. Its points are refined by the matched
    fit along the path's normal and tested as lines (`line_test.is_line`, heights
    ≥ MIN_HEIGHT_C·c); the bridge is accepted when at least MIN_PASS_SHARE of them pass and
    no run of failures is longer than MAX_MISS_PX, and then holds the passing points.
    """
    chains = [c for c in chains if c.size >= 2]
    empty = np.zeros(0, GEOMETRY_FLOAT)
    ends = _ends(x, y, sigma, chains) if chains else np.zeros((0, 5))
    pairs = _facing_pairs(ends) if len(ends) else []
    found = []
    frame = np.asarray(image, np.float32)
    for i, j in pairs:
        rest = [c for k, c in enumerate(chains) if k not in (i // 2, j // 2)]
        others = cKDTree(np.column_stack([x, y])[np.concatenate(rest)]) if rest else None
        bridge = _bridge(frame, ends[i], ends[j], others, width_min=width_min_px, c_grey=c_grey)
        if bridge is not None and bridge[0].size:
            found.append(bridge)
    if not found:
        return Bridges(empty, empty, empty, empty, empty, empty, (), len(pairs))
    sizes = [f[0].size for f in found]
    bounds = np.cumsum([0, *sizes])
    return Bridges(
        x=np.concatenate([f[0] for f in found]),
        y=np.concatenate([f[1] for f in found]),
        nx=np.concatenate([f[2] for f in found]),
        ny=np.concatenate([f[3] for f in found]),
        sigma=np.concatenate([np.full(n, f[5]) for f, n in zip(found, sizes, strict=True)]),
        strength=np.concatenate([f[4] for f in found]),
        chains=tuple(
            np.arange(lo, hi, dtype=np.int64)
            for lo, hi in zip(bounds[:-1], bounds[1:], strict=True)
        ),
        gaps=len(pairs),
    )
