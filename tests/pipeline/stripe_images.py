"""Synthetic wheel-stripe frames with exact truth, and the accuracy score against that truth.

The centre line follows a wheel profile as a camera sees it: the flange back rising from the
bottom edge, the flange top bending with a 100 px radius, the flank, a 60 px concave root and
the nearly flat tread leaving the right edge. Across the line the intensity is Gaussian with a
1/e² full width w(τ) that may vary along the arc length τ; the truth is the line itself,
sampled every 0.05 px. Shot noise, read noise, low-grey stretches, clutter blobs, a short
stripe of another part and saturation are optional; frames come as uint8 or uint16.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np
from scipy.spatial import cKDTree

TRUTH_STEP_PX = 0.05
"""Spacing of the dense truth samples along the centre line [px]."""

PEAK_GREY = 170.0
BACKGROUND_GREY = 12.0
SHOT_GAIN = 0.25
"""Shot noise variance per grey level (≈ 4 electrons per 8-bit grey level)."""

EVAL_MARGIN_PX = 10
"""Truth and points this close to the frame edge are not scored (reflected border)."""

FALSE_DISTANCE_PX = 3.0
GAP_ARC_PX = 1.5


@dataclass(frozen=True)
class StripeCase:
    """Recipe of one synthetic frame; widths are 1/e² full widths [px]."""

    name: str
    shape: tuple[int, int] = (400, 640)
    width_start_px: float = 5.0
    width_end_px: float = 21.0
    read_noise: float = 0.0
    shot_noise: bool = False
    low_grey: bool = False
    clutter: bool = False
    other_part: bool = False
    saturation: bool = False
    bits: int = 8
    seed: int = 0


@dataclass(frozen=True, eq=False)
class SyntheticStripe:
    """A rendered frame with its truth centre line (dense samples, x = column, y = row)."""

    case: StripeCase
    image: np.ndarray
    line_xy: np.ndarray
    arc_px: np.ndarray
    width_px: np.ndarray
    extras: list[np.ndarray] = field(default_factory=list)


def _turtle(start_xy, heading_deg, moves, step=TRUTH_STEP_PX) -> np.ndarray:
    """Dense points of a path of straight runs (length, 0) and arcs (radius, turn_deg)."""
    points = [np.asarray(start_xy, float)]
    heading = np.deg2rad(heading_deg)
    for length, turn_deg in moves:
        if turn_deg == 0:
            n = int(round(length / step))
            ds = np.full(n, length / n)
            dh = np.zeros(n)
        else:
            arc = abs(np.deg2rad(turn_deg)) * length
            n = int(round(arc / step))
            ds = np.full(n, arc / n)
            dh = np.full(n, np.deg2rad(turn_deg) / n)
        # Exact arc increments: chord of each small arc along its mid heading.
        headings = heading + np.cumsum(dh) - dh / 2
        chord = np.where(dh == 0, ds, 2 * ds / np.where(dh == 0, 1, dh) * np.sin(dh / 2))
        steps = np.stack([chord * np.cos(headings), chord * np.sin(headings)], axis=1)
        points.extend(points[-1] + np.cumsum(steps, axis=0))
        heading += dh.sum()
    return np.asarray(points)


def wheel_line(shape: tuple[int, int]) -> np.ndarray:
    """Dense truth centre line of a wheel profile fitted to a frame (rows, cols)."""
    rows, cols = shape
    scale = cols / 640
    moves = [
        (rows * 0.62, 0),  # flange back, rising
        (100.0, 160),  # flange top, radius 100 px (image y down: positive turn = clockwise)
        (rows * 0.2, 0),  # flank, falling
        (60.0, -78),  # flange root, concave
        (cols * 1.2, 0),  # tread, leaving the frame
    ]
    start = (90 * scale, rows + 25)
    return _turtle(start, -80.0, moves)


def _project(tree: cKDTree, line: np.ndarray, arc: np.ndarray, xy: np.ndarray):
    """Distance [px] of points to the dense line and the arc length of their projection."""
    _, k = tree.query(xy)
    best_d = np.full(len(xy), np.inf)
    best_s = np.zeros(len(xy))
    for a, b in ((k - 1, k), (k, k + 1)):
        a = np.clip(a, 0, len(line) - 1)
        b = np.clip(b, 0, len(line) - 1)
        seg = line[b] - line[a]
        length2 = np.maximum((seg**2).sum(axis=1), 1e-12)
        u = np.clip(((xy - line[a]) * seg).sum(axis=1) / length2, 0, 1)
        foot = line[a] + u[:, None] * seg
        d = np.hypot(*(xy - foot).T)
        better = d < best_d
        best_d[better] = d[better]
        best_s[better] = (arc[a] + u * (arc[b] - arc[a]))[better]
    return best_d, best_s


def _render_line(shape, line, width, peak) -> np.ndarray:
    """Gaussian-profile stripe along `line`: peak(τ)·exp(−8 d²/w(τ)²) at every pixel centre."""
    arc = np.concatenate([[0], np.cumsum(np.hypot(*np.diff(line, axis=0).T))])
    reach = 2.0 * width.max()
    band = np.zeros(shape, np.uint8)
    cv2.polylines(band, [np.rint(line[::20]).astype(np.int32)], False, 1, int(2 * reach + 3))
    rows, cols = np.nonzero(band)
    xy = np.stack([cols, rows], axis=1).astype(float)
    tree = cKDTree(line)
    d, s = _project(tree, line, arc, xy)
    k = np.clip(np.searchsorted(arc, s), 0, len(arc) - 1)
    out = np.zeros(shape)
    out[rows, cols] = np.where(d <= reach, peak[k] * np.exp(-8 * d**2 / width[k] ** 2), 0)
    return out


def _smoothstep(t: np.ndarray) -> np.ndarray:
    t = np.clip(t, 0, 1)
    return t * t * (3 - 2 * t)


def _clutter(rng, shape, line) -> np.ndarray:
    """Round blobs (stray spots) at least 30 px from the line: σ 2-6 px, peak 80-200."""
    tree = cKDTree(line)
    out = np.zeros(shape)
    rows, cols = np.mgrid[0 : shape[0], 0 : shape[1]]
    placed = 0
    while placed < 12:
        cx, cy = rng.uniform(20, shape[1] - 20), rng.uniform(20, shape[0] - 20)
        if tree.query([cx, cy])[0] < 30:
            continue
        sig = rng.uniform(2, 6)
        out += rng.uniform(80, 200) * np.exp(-((cols - cx) ** 2 + (rows - cy) ** 2) / (2 * sig**2))
        placed += 1
    return out


def _other_part(shape, line) -> np.ndarray:
    """Short straight stripe of another part (brake shoe, axle box): 110 px, w 7, peak 150."""
    rows, cols = shape
    start = np.array([cols * 0.62, rows * 0.18])
    direction = np.array([np.cos(0.3), np.sin(0.3)])
    n = int(110 / TRUTH_STEP_PX)
    other = start + np.arange(n)[:, None] * TRUTH_STEP_PX * direction
    assert cKDTree(line).query(other)[0].min() > 40
    return other


def make_stripe(case: StripeCase) -> SyntheticStripe:
    """Render the frame of `case` with its truth."""
    rng = np.random.default_rng(case.seed)
    line = wheel_line(case.shape)
    arc = np.concatenate([[0], np.cumsum(np.hypot(*np.diff(line, axis=0).T))])
    tau = arc / arc[-1]
    width = case.width_start_px + (case.width_end_px - case.width_start_px) * _smoothstep(
        (tau - 0.1) / 0.6
    )
    peak = np.full(len(line), PEAK_GREY)
    if case.low_grey:
        # Two stretches at 25 % of the peak (worn, highly reflective tread; flange root).
        for centre in (0.45, 0.75):
            peak *= 1 - 0.75 * np.exp(-0.5 * ((tau - centre) / 0.03) ** 2)
    if case.saturation:
        peak *= 2.5
    image = BACKGROUND_GREY + _render_line(case.shape, line, width, peak)
    extras = []
    if case.other_part:
        other = _other_part(case.shape, line)
        image += _render_line(
            case.shape, other, np.full(len(other), 7.0), np.full(len(other), 150.0)
        )
        extras.append(other)
    if case.clutter:
        image += _clutter(rng, case.shape, line)
    if case.shot_noise:
        image = image + rng.normal(size=image.shape) * np.sqrt(SHOT_GAIN * image)
    image = image + rng.normal(scale=case.read_noise, size=image.shape)
    if case.bits == 16:
        frame = np.clip(np.rint(image * 257), 0, 65535).astype(np.uint16)
    else:
        frame = np.clip(np.rint(image), 0, 255).astype(np.uint8)
    return SyntheticStripe(case, frame, line, arc, width, extras)


@dataclass(frozen=True)
class Score:
    """Accuracy of extracted centres against the truth line (scored area: EVAL_MARGIN_PX in)."""

    points: int
    rms_px: float
    max_error_px: float
    false_pct: float
    max_gap_px: float
    coverage_pct: float


def score_centres(stripe: SyntheticStripe, x: np.ndarray, y: np.ndarray) -> Score:
    """RMS distance of true points, false points (> 3 px off), largest gap and coverage.

    Notes
    -----
    Points within 3 px of the truth are "true"; their RMS distance is `rms_px`. Each true
    point is projected on the line (arc length); the largest stretch of the scored line not
    within 1.5 px of arc length of a projection is `max_gap_px` (0 when every point of the
    line is covered), and `coverage_pct` is the covered fraction of the scored line.
    """
    rows, cols = stripe.image.shape
    m = EVAL_MARGIN_PX
    xy = np.stack([x, y], axis=1)
    inside = (x >= m) & (x <= cols - 1 - m) & (y >= m) & (y <= rows - 1 - m)
    xy = xy[inside]
    line = stripe.line_xy
    scored = (
        (line[:, 0] >= m)
        & (line[:, 0] <= cols - 1 - m)
        & (line[:, 1] >= m)
        & (line[:, 1] <= rows - 1 - m)
    )
    d, s = _project(cKDTree(line), line, stripe.arc_px, xy) if len(xy) else (np.zeros(0),) * 2
    true = d <= FALSE_DISTANCE_PX
    arc = stripe.arc_px[scored]
    covered = np.zeros(len(arc), bool)
    if true.any():
        proj = np.sort(s[true])
        k = np.clip(np.searchsorted(proj, arc), 1, len(proj) - 1) if len(proj) > 1 else 0
        nearest = np.minimum(np.abs(arc - proj[np.maximum(k - 1, 0)]), np.abs(arc - proj[k]))
        covered = nearest <= GAP_ARC_PX
    gaps = _runs(~covered) * TRUTH_STEP_PX
    return Score(
        points=int(len(xy)),
        rms_px=float(np.sqrt(np.mean(d[true] ** 2))) if true.any() else float("nan"),
        max_error_px=float(d[true].max()) if true.any() else float("nan"),
        false_pct=float(100 * (~true).sum() / max(len(xy), 1)),
        max_gap_px=float(gaps),
        coverage_pct=float(100 * covered.mean()) if len(arc) else 0.0,
    )


def _runs(flags: np.ndarray) -> int:
    """Length of the longest run of True."""
    if not flags.any():
        return 0
    padded = np.concatenate([[0], flags.astype(np.int8), [0]])
    edges = np.flatnonzero(np.diff(padded))
    return int((edges[1::2] - edges[::2]).max())
