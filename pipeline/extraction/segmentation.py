"""Which components of a ridge-response mask are the stripe: shape, ridge strength, length
and continuity.

The laser stripe is the brightest narrow ridge of a frame. A component is a stripe piece
when it is shaped like one (not a spot), its ridge strength is comparable to the strongest
piece's or strong in itself (a dimmer outline, texture, a ghost stripe are neither), and
it is either long beside the other strong pieces or continues one of those kept (the
pieces of a stripe broken at depth steps). After the centres are linked, the chains of a
whole frame are joined into lines, pieces whose ends lie near another piece and not beside
it (within LINE_SIDE_PX of the end's tangent line), and only lines of about the longest's
length are kept (`longest_lines`): the laser plane cuts the surfaces in view along one
curve, so a bright line apart from it, or running alongside it, and far shorter (a
specular glint, a torch's lit rims) is not the stripe. Another part's bright stripe as
long, or one inside a search region, may still pass here; measurement rejects it later
by its place in the track frame.
"""

from __future__ import annotations

import numpy as np

from pipeline.extraction.components import ComponentShapes, tree_labels, union
from pipeline.jit import kernel

MIN_COMPONENT_AREA_PX = 40
"""Components smaller than this [px²] are noise or stray spots, never a stripe."""

MIN_ELONGATION = 2.0
"""Least elongation L²/A of a stripe component (L: length of the uniform bar with the same
second moment, A: area). A disc has 0.95, a square 1, an L:w bar L/w: a short piece of a
wide stripe (a 19 px stripe cut to 50 px, its mask ≈ 25 px wide) still has 2."""

STRONG_FRACTION = 0.4
"""A stripe piece's ridge strength (its largest C = σ²|λ1| [grey levels]) is at least this
share of the strongest candidate's. A Gaussian line of peak A has C ≈ 0.385·A at its best
scale whatever its width, so this is a share of the peak contrast: a ghost at 10–30 %, the
texture and the outlines of a lit scene (C ≲ 0.15 of the laser's) fall below it; a laser
stretch dimmed to 25 % stays kept with the component it belongs to."""

STRONG_C_RATIO = 10.0
"""A candidate whose strength is at least this many times the ridge response's structure
constant c (`ridges.RIDGE_C_FULL_SCALE`: 0.01 of full scale, 2.55 grey levels for 8 bit) is
strong whatever else the frame holds: C ≥ 25.5 grey levels is a Gaussian line of peak
contrast ≥ 66 grey levels, ≥ 6σ of a read noise of 10. A stripe dimmed where the laser
grazes the wheel's back face (C 30–37 beside the tread's 94–104 on simulated inner frames,
0.31–0.39 of it) is one; a ghost of 20 % of a saturated laser (C ≤ 19.6), the texture and
outlines of a lit scene (C 11–15 beside a laser's 66) are not."""

CHAIN_FRACTION = 0.5
"""A short linked chain of centres is the stripe's only when its highest line (the
unsmoothed profile's height above the brighter side, `line_test.line_profiles`) is at least
this share of the highest chain's. Inside a kept component, texture ridges and bits of
outline beside the laser are linked apart from the laser's own chain, short and a fraction
of its height; the dimmest piece of a broken stripe (0.8 of the peak beside one at 1.25)
has 0.64."""

CHAIN_MIN_POINTS = 30
"""A chain dimmer than CHAIN_FRACTION of the highest is kept only when it has at least this
many centres (about as many px along the stripe) and is strong in itself (STRONG_C_RATIO)
or lies within CONTINUITY_GAP_PX of a kept chain: a dim stretch of the laser linked apart
from its bright parts (on real frames a quarter of their height) is long and beside them;
texture ridges are short, and flare streaks and dim outlines (C 4–10 on the real frames,
22–28 px from the nearest laser chain) lie apart."""

CHAIN_WIDTH_FACTOR = 1.5
"""A linked chain of centres is the stripe's only when at most half of its points measure
wider than this multiple of the widest stripe expected (`width_max`), or have no width
(an edge beyond the search reach, `widths.stripe_widths`). The measured 1/e² width of a
stripe of the configured range stays within it (uniform 21 px: 21.1 median, saturated
2.5× at 21 px: 23 at the 90th percentile; real laser lines 7–26 px at the default
5–21); a lit bar, a broad glow or the halo of a specular highlight measures 35–95 px."""

LINE_JOIN_PX = 40.0
"""Two linked chains of centres are pieces of one line when an end of one lies within this
distance [px] of a centre of the other (not beside it: LINE_SIDE_PX): consecutive pieces
of a stripe broken at depth steps (up to 16 px of it hidden, the next piece shifted by up
to 19 px along the rows, which along a steep stretch lengthens the gap, and each cut end
trimmed by the line test) lie 9–38 px apart end to end on `broken-steps` and `field-all`."""

LINE_SIDE_PX = 20.0
"""... and that centre lies within this distance [px] of the end's tangent line (ahead of
the end or behind it): the next piece of a broken stripe continues the line, shifted
sideways by at most the depth step (≤ 19 px on `broken-steps`, and 12–18 px where pieces
of `broken-steps`, `field-all` and the real frames' crossing laser lines join), while a
line beside it runs alongside: the welding torch's rims and highlight, parallel lines 26–30
px apart, and the lit wire below it, 27–29 px beside the end of a rim, were joined end to
side and, through the wire, to the laser line (real frames weld-2, weld-8)."""

END_TANGENT_POINTS = 6
"""Centres over which a chain's direction at its end is taken."""

LINE_KEEP_FRACTION = 0.5
"""Outside a search region, a line (its chains joined by LINE_JOIN_PX) is the stripe's only
when it holds at least this share of the centres of the line holding the most: the laser
plane cuts the surfaces in view along one curve, broken only where depth steps hide it, so
its pieces joined make the longest line of the frame. A specular line apart from it (the
rail head's polished band, a polished rod's glints: as narrow and nearly as bright as the
laser, darker on both sides) is 0.27–0.30 of it on the lit synthetic scenes."""

KEEP_FRACTION = 0.3
"""Strong components at least this share of the longest strong one's length are kept as
stripe pieces; shorter ones only when they continue a kept piece."""

CONTINUITY_GAP_PX = 16.0
"""A strong piece within this distance [px] of a kept one continues it (the cuts of a
stripe broken at depth steps hide up to 16 px of it, and the pieces shift sideways by up
to 12 px)."""


def stripe_components(
    shapes: ComponentShapes,
    strength: np.ndarray,
    near: np.ndarray | None,
    c_grey: float,
    *,
    every_strong: bool = False,
) -> np.ndarray:
    """Which components (index 0: background, never) are parts of the stripe (bool (K,)).

    Parameters
    ----------
    shapes : ComponentShapes
        Area, length and elongation of components 0..K − 1.
    strength : ndarray of shape (K,)
        Largest ridge strength C = σ²|λ1| on each component [grey levels].
    near : ndarray of shape (P, 2), int64, or None
        The pairs of `continuity_labels` within CONTINUITY_GAP_PX of each other
        (`components.labels_within`, each pair once); None when those are None (no
        component is left that continuity could add).
    c_grey : float
        The ridge response's structure constant c [grey levels].
    every_strong : bool
        Keep every strong candidate: inside the search region the calibration bounds
        (`pipeline.calibration.search_region`), where other parts' stripes, longer than a
        piece of the wheel's, are mostly left out and measurement rejects the rest by their
        place in the track frame; and the compact strong components that continue them
        (`compact_strong`).

    Notes
    -----
    Candidates have area ≥ MIN_COMPONENT_AREA_PX and elongation ≥ MIN_ELONGATION; strong ones
    a strength ≥ STRONG_FRACTION of the strongest candidate's or ≥ STRONG_C_RATIO·c. Strong
    ones at least KEEP_FRACTION of the longest strong one's length are kept (every strong
    one with `every_strong`), then every strong one (with `every_strong`: every compact
    strong one) within CONTINUITY_GAP_PX of a kept one, until none is added.
    """
    strong = strong_candidates(shapes, strength, c_grey)
    if not strong.any():
        return strong
    if every_strong:
        keep, joining = strong, compact_strong(shapes, strength, c_grey)
    else:
        keep, joining = _long_enough(shapes, strong), strong
    if near is None:
        return keep
    while True:
        reached = np.zeros(keep.size, bool)
        reached[near[keep[near[:, 0]], 1]] = True
        reached[near[keep[near[:, 1]], 0]] = True
        grown = keep | (joining & reached)
        if (grown == keep).all():
            return keep
        keep = grown


def _long_enough(shapes: ComponentShapes, strong: np.ndarray) -> np.ndarray:
    """Strong candidates ≥ KEEP_FRACTION of the longest strong one's length (some strong)."""
    return strong & (shapes.length_px >= KEEP_FRACTION * shapes.length_px[strong].max())


def continuity_labels(
    shapes: ComponentShapes, strength: np.ndarray, c_grey: float, every_strong: bool
) -> np.ndarray | None:
    """The components whose pairs within CONTINUITY_GAP_PX `stripe_components` reads (bool
    (K,)): the strong candidates, and with `every_strong` the compact strong components too;
    None when continuity can add none (no strong candidate too short to be kept by its
    length; with `every_strong`, no compact strong component). Then the pairs are never
    found (on a frame with one stripe, finding them cost about as much as labelling the
    mask)."""
    strong = strong_candidates(shapes, strength, c_grey)
    if not strong.any():
        return None
    if every_strong:
        compact = compact_strong(shapes, strength, c_grey)
        return strong | compact if compact.any() else None
    return strong if (strong & ~_long_enough(shapes, strong)).any() else None


def candidates(shapes: ComponentShapes) -> np.ndarray:
    """Components shaped like a stripe piece (bool (K,), index 0 False)."""
    shaped = (shapes.area_px >= MIN_COMPONENT_AREA_PX) & (shapes.elongation >= MIN_ELONGATION)
    shaped[0] = False
    return shaped


def _least_strength(shapes: ComponentShapes, strength: np.ndarray, c_grey: float) -> float:
    """The strength a strong candidate needs [grey levels]: STRONG_FRACTION of the strongest
    candidate's, at most STRONG_C_RATIO·c_grey (inf when there is no candidate)."""
    shaped = candidates(shapes)
    if not shaped.any():
        return float("inf")
    return min(STRONG_FRACTION * float(strength[shaped].max()), STRONG_C_RATIO * c_grey)


def strong_candidates(shapes: ComponentShapes, strength: np.ndarray, c_grey: float) -> np.ndarray:
    """Candidates whose strength is ≥ STRONG_FRACTION of the strongest candidate's or
    ≥ STRONG_C_RATIO·c_grey [grey levels]."""
    return candidates(shapes) & (strength >= _least_strength(shapes, strength, c_grey))


def compact_strong(shapes: ComponentShapes, strength: np.ndarray, c_grey: float) -> np.ndarray:
    """Components of area ≥ MIN_COMPONENT_AREA_PX, elongation < MIN_ELONGATION and the strength
    of a strong candidate (bool (K,), index 0 False): a search region keeps those within
    CONTINUITY_GAP_PX of a kept piece (`stripe_components`), the stretches of glare on a
    polished flank, fused by their bloom and the dim stripe between into one blob of
    elongation 1.1–1.8 (docs/simulator.md, "Compact glare blobs on the flank", pipeline 0.11.12)."""
    compact = (shapes.area_px >= MIN_COMPONENT_AREA_PX) & (shapes.elongation < MIN_ELONGATION)
    compact[0] = False
    return compact & (strength >= _least_strength(shapes, strength, c_grey))


def chain_ends(x: np.ndarray, y: np.ndarray, chains: list[np.ndarray]) -> np.ndarray:
    """Both ends of each chain: (2·len(chains), 4) rows (x, y, tx, ty), tx, ty the unit
    direction out of the chain over its last END_TANGENT_POINTS centres."""
    ends = np.zeros((2 * len(chains), 4))
    if not chains:
        return ends
    points = np.concatenate(chains)
    size = np.fromiter((c.size for c in chains), np.int64, len(chains))
    first = np.cumsum(size) - size
    k = np.minimum(END_TANGENT_POINTS, size) - 1
    # Rows 2i and 2i + 1: chain i's first end (inner point k on) and its last.
    end = np.stack([points[first], points[first + size - 1]], axis=1).ravel()
    inner = np.stack([points[first + k], points[first + size - 1 - k]], axis=1).ravel()
    tx, ty = x[end] - x[inner], y[end] - y[inner]
    norm = np.maximum(np.hypot(tx, ty), 1e-9)
    ends[:, 0], ends[:, 1], ends[:, 2], ends[:, 3] = x[end], y[end], tx / norm, ty / norm
    return ends


def chain_maxima(values: np.ndarray, chains: list[np.ndarray]) -> np.ndarray:
    """The largest of `values` (one per centre) on each chain, for all chains at once (a lit
    frame has hundreds): (len(chains),), NaN where a chain holds a NaN (as `ndarray.max`).
    Chains must not be empty."""
    points = np.concatenate(chains)
    size = np.fromiter((c.size for c in chains), np.int64, len(chains))
    return np.maximum.reduceat(values[points], np.cumsum(size) - size)


@kernel
def _box_pairs(x, y, ex, ey, reach):
    """The pairs (end, point) of ends (ex, ey) and points (x, y) [px] at most `reach` apart
    along both axes: (P,) int64 each, a superset of the pairs within `reach`. The points
    are sorted by x once and each end reads only those of its x span."""
    order = np.argsort(x, kind="mergesort")
    sx = x[order]
    lo = np.searchsorted(sx, ex - reach)
    hi = np.searchsorted(sx, ex + reach, side="right")
    count = 0
    for e in range(ex.size):
        for i in range(lo[e], hi[e]):
            count += abs(y[order[i]] - ey[e]) <= reach
    ends = np.empty(count, np.int64)
    points = np.empty(count, np.int64)
    count = 0
    for e in range(ex.size):
        for i in range(lo[e], hi[e]):
            if abs(y[order[i]] - ey[e]) <= reach:
                ends[count], points[count] = e, order[i]
                count += 1
    return ends, points


@kernel
def _components(a, b, size):
    """Connected components of the graph of `size` nodes with the edges a[k]–b[k]: each
    node's label (int64, 0 …)."""
    parent = np.arange(size)
    for k in range(a.size):
        union(parent, a[k], b[k])
    return tree_labels(parent, 0)[0]


_BOX_SLACK_PX = 1e-6
"""Widening of the squares searched around each end [px]: a centre whose squared distance
rounds to LINE_JOIN_PX² may lie a hair beyond it along an axis."""


def joined_lines(xy: np.ndarray, chains: list[np.ndarray]) -> np.ndarray:
    """Which line each chain belongs to (int (len(chains),)): chains are joined when an end of
    one lies within LINE_JOIN_PX of a centre of the other that lies within LINE_SIDE_PX of
    the end's tangent line (`chain_ends`), transitively. `xy` (K, 2) are the centres [px],
    `chains` index arrays into it.

    The centres within reach of each end: those of its square (`_box_pairs`), then the
    distance test of a k-d tree's leaves (the squares summed, against LINE_JOIN_PX²; a
    tree built for a few ends cost more than the rest of the chain rules).
    """
    order = np.concatenate(chains)
    owner = np.repeat(np.arange(len(chains)), [c.size for c in chains])
    ends = chain_ends(xy[:, 0], xy[:, 1], chains)
    at = xy[order]
    rows, hits = _box_pairs(
        np.ascontiguousarray(at[:, 0]),
        np.ascontiguousarray(at[:, 1]),
        np.ascontiguousarray(ends[:, 0]),
        np.ascontiguousarray(ends[:, 1]),
        LINE_JOIN_PX + _BOX_SLACK_PX,
    )
    gap = at[hits] - ends[rows, :2]
    within = gap[:, 0] * gap[:, 0] + gap[:, 1] * gap[:, 1] <= LINE_JOIN_PX * LINE_JOIN_PX
    rows, hits, gap = rows[within], hits[within], gap[within]
    side = np.abs(gap[:, 0] * ends[rows, 3] - gap[:, 1] * ends[rows, 2])
    rows, cols = rows[side <= LINE_SIDE_PX] // 2, owner[hits[side <= LINE_SIDE_PX]]
    return _components(rows, cols, len(chains))


def longest_lines(xy: np.ndarray, chains: list[np.ndarray]) -> np.ndarray:
    """Which chains (bool (len(chains),)) belong to a line (`joined_lines`) holding at least
    LINE_KEEP_FRACTION of the centres of the line holding the most."""
    if len(chains) < 2:  # one chain is its own longest line
        return np.ones(len(chains), bool)
    line = joined_lines(xy, chains)
    count = np.bincount(line, weights=[c.size for c in chains])
    return count[line] >= LINE_KEEP_FRACTION * count.max()
