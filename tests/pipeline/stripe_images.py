"""Synthetic wheel-stripe frames with exact truth, and the accuracy score against that truth.

The centre line follows a wheel profile as a camera sees it: the flange back rising from the
bottom edge, the flange top bending with a 100 px radius, the flank, a 60 px concave root and
the nearly flat tread leaving the right edge. Across the line the intensity is Gaussian with a
1/e² full width w(τ) that may vary along the arc length τ; the truth is the line itself,
sampled every 0.05 px. Shot noise, read noise, low-grey stretches, clutter blobs, a short
stripe of another part and saturation are optional; frames come as uint8 or uint16.

The field-harsh cases (docs/extraction-cases.md) add a lit, textured scene with bright edges
behind the stripe (stripe_scenes), a stripe broken into offset segments of different widths
at depth steps, a faint ghost stripe beside the real one and an asymmetric cross-section
(a different reflectance each side of the centre). Their truth is the stripe's centre line
(one polyline per segment) and the pixels the laser lights (`laser_mask`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np
from scipy.ndimage import gaussian_filter, map_coordinates
from scipy.spatial import cKDTree
from scipy.special import erfc

from tests.pipeline.stripe_scenes import EDGE_BLUR_PX, lit_scene

TRUTH_STEP_PX = 0.05
"""Spacing of the dense truth samples along the centre line [px]."""

PEAK_GREY = 170.0
BACKGROUND_GREY = 12.0
SHOT_GAIN = 0.25
"""Shot noise variance per grey level (≈ 4 electrons per 8-bit grey level)."""

CUT_BLUR_PX = 1.0
"""Blur along the stripe of a segment's end at a depth step: Gaussian σ [px] (optics)."""

BROKEN_BREAKS = (0.2, 0.28, 0.45, 0.52, 0.8)
"""Where the broken stripe is cut, as fractions of its arc inside the frame (0 where the line
enters the frame, 1 where it leaves)."""
BROKEN_GAPS_PX = (10.0, 14.0, 8.0, 16.0, 12.0)
"""Length of the stripe hidden at each cut [px of arc]."""
BROKEN_SHIFTS_PX = (0.0, -9.0, 6.0, -12.0, 7.0, -5.0)
"""Image shift of each segment at its depth, along the rows [px]."""
BROKEN_WIDTHS_PX = (7.0, 15.0, 5.0, 19.0, 10.0, 13.0)
"""1/e² full width of each segment [px]."""
BROKEN_GAINS = (1.0, 1.2, 0.8, 0.9, 1.25, 0.95)
"""Peak of each segment relative to the case's peak (surface angle and reflectance)."""

SPECKLE_SIGMA_PX = 1.2
"""Correlation of the laser speckle on the stripe: Gaussian σ of its smoothed white noise [px]
(the grain seen along the real frames' lines)."""

GHOST_SPAN = (0.72, 0.97)
"""Stretch of the line reflected as a ghost, as fractions of its arc inside the frame: the
tread next to the flange."""
GHOST_SHIFT_PX = 30.0
GHOST_WIDENING = 1.4
"""The ghost lies GHOST_SHIFT_PX below the stripe [px], GHOST_WIDENING× as wide (diffuse)."""

FLARE_AT = 0.7
"""Where the flare starts, as a fraction of the stripe's arc inside the frame: the flange root."""
FLARE_LENGTHS_PX = (60.0, 130.0, 80.0, 110.0, 50.0, 120.0, 70.0, 100.0)
"""Radial streaks of the flare, one per 45° from 20°, starting 8 px out [px long]."""
FLARE_PEAK_GREY = 50.0
FLARE_WIDTH_PX = 3.0
"""A streak's peak where it starts, fading linearly to 0 at its end, and its 1/e² width."""
GLARE_PEAK_GREY = 150.0
GLARE_SIGMA_PX = 3.0
"""The glare spot at the flare's origin, on the stripe: peak above it and Gaussian σ."""


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
    peak_grey: float = PEAK_GREY
    scene: str = "dark"
    broken: bool = False
    ghost_ratio: float = 0.0
    asymmetry: float = 1.0
    speckle: float = 0.0
    flare: bool = False
    """Field-harsh options: `peak_grey` the stripe's peak above the background (8-bit
    levels); `scene` "dark" (BACKGROUND_GREY), "lit" (lit plates beside the stripe),
    "lit-crossing" (plate edges crossing it) or "lit-specular" ("lit" with specular glints);
    `broken` the stripe cut into BROKEN_* segments; `ghost_ratio` the ghost's peak relative to
    the stripe's (0: none); `asymmetry` the reflectance left of the centre relative to the
    right's (1: symmetric); `speckle` the standard deviation of the laser speckle multiplying
    the stripe, relative to its mean (correlated over SPECKLE_SIGMA_PX); `flare` radial
    streaks and a glare spot where the stripe bends at the flange root (FLARE_*, GLARE_*)."""


@dataclass(frozen=True, eq=False)
class SyntheticStripe:
    """A rendered frame with its truth centre line (dense samples, x = column, y = row).

    `segment` numbers the samples' segments (0 for an unbroken stripe); `arc_px` is the arc
    length of the unbroken line, so it jumps where a cut hides part of it. `end_zone` marks
    samples within half a width of a cut end, where no cross-section is defined (not
    scored). `bound_px` is each sample's noise bound (`noise_bound_px`). `laser_mask` holds
    the pixels the stripe lights to at least e⁻² of its peak; `extras` are lines that are not
    the stripe (another part, a ghost, edge highlights).
    """

    case: StripeCase
    image: np.ndarray
    line_xy: np.ndarray
    arc_px: np.ndarray
    width_px: np.ndarray
    segment: np.ndarray
    end_zone: np.ndarray
    bound_px: np.ndarray
    laser_mask: np.ndarray
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


@dataclass(frozen=True, eq=False)
class LineProjection:
    """Feet of points on a dense line: distance [px], arc length [px], side (±1), sample."""

    distance_px: np.ndarray
    arc_px: np.ndarray
    side: np.ndarray
    index: np.ndarray


def project_on_line(tree, line, arc, xy, segment=None) -> LineProjection:
    """Project points on the dense line, never across a cut between two `segment` numbers.

    `side` is the sign of (line direction × offset): −1 left of the line's direction on the
    image (y down), +1 right of it.
    """
    _, k = tree.query(xy)
    best_d = np.full(len(xy), np.inf)
    best_s = np.zeros(len(xy))
    best_side = np.ones(len(xy))
    for a, b in ((k - 1, k), (k, k + 1)):
        a = np.clip(a, 0, len(line) - 1)
        b = np.clip(b, 0, len(line) - 1)
        if segment is not None:
            a = np.where(segment[a] == segment[k], a, k)
            b = np.where(segment[b] == segment[k], b, k)
        seg = line[b] - line[a]
        length2 = np.maximum((seg**2).sum(axis=1), 1e-12)
        u = np.clip(((xy - line[a]) * seg).sum(axis=1) / length2, 0, 1)
        foot = line[a] + u[:, None] * seg
        offset = xy - foot
        d = np.hypot(*offset.T)
        cross = seg[:, 0] * offset[:, 1] - seg[:, 1] * offset[:, 0]
        better = d < best_d
        best_d[better] = d[better]
        best_s[better] = (arc[a] + u * (arc[b] - arc[a]))[better]
        best_side[better] = np.where(cross < 0, -1.0, 1.0)[better]
    return LineProjection(best_d, best_s, best_side, k)


def _cut_ends(line, arc, xy, foot: LineProjection):
    """Distance across the end tangents past the line's ends, and the fade of a sharp end.

    A stripe that ends at a depth step stops at the end sample, blurred along the line by
    CUT_BLUR_PX: fade = ½·erfc(t / (√2·CUT_BLUR_PX)), t the signed distance past the end.
    """
    d = foot.distance_px.copy()
    fade = np.ones(len(xy))
    for end, inner in ((0, 1), (-1, -2)):
        tangent = line[end] - line[inner]
        tangent /= np.hypot(*tangent)
        offset = xy - line[end]
        beyond = offset @ tangent
        past = (beyond > 0) & (foot.arc_px == arc[end])
        d[past] = np.abs(offset[past, 0] * tangent[1] - offset[past, 1] * tangent[0])
        along = np.where(past, beyond, -np.abs(foot.arc_px - arc[end]))
        fade *= 0.5 * erfc(along / (np.sqrt(2) * CUT_BLUR_PX))
    return d, fade


def _render_line(shape, line, width, peak, *, cut_ends=False, left_gain=1.0):
    """Gaussian-profile stripe along `line`: peak(τ)·exp(−8 d²/w(τ)²) at every pixel centre.

    With `cut_ends` the stripe stops sharply at the line's ends (`_cut_ends`) instead of
    fading round them. `left_gain` scales the side left of the line's direction (a
    reflectance step at the centre, blurred by the optics' EDGE_BLUR_PX). Returns the grey
    and the mask of the pixels lit to at least e⁻² of the local peak (|d| ≤ w/2).
    """
    arc = np.concatenate([[0], np.cumsum(np.hypot(*np.diff(line, axis=0).T))])
    reach = 2.0 * width.max()
    band = np.zeros(shape, np.uint8)
    cv2.polylines(band, [np.rint(line[::20]).astype(np.int32)], False, 1, int(2 * reach + 3))
    rows, cols = np.nonzero(band)
    xy = np.stack([cols, rows], axis=1).astype(float)
    foot = project_on_line(cKDTree(line), line, arc, xy)
    d, fade = _cut_ends(line, arc, xy, foot) if cut_ends else (foot.distance_px, 1.0)
    k = np.clip(np.searchsorted(arc, foot.arc_px), 0, len(arc) - 1)
    profile = np.where(d <= reach, peak[k] * np.exp(-8 * d**2 / width[k] ** 2), 0) * fade
    if left_gain != 1.0:
        right = 0.5 * erfc(-foot.side * d / (np.sqrt(2) * EDGE_BLUR_PX))
        profile *= left_gain + (1 - left_gain) * right
    out = np.zeros(shape)
    out[rows, cols] = profile
    lit = np.zeros(shape, bool)
    lit[rows, cols] = (d <= width[k] / 2) & (np.asarray(fade) >= 0.5)
    return out, lit


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


@dataclass(frozen=True, eq=False)
class _Piece:
    """A stretch of line to render: dense samples, arc of the unbroken line, widths, peaks."""

    line: np.ndarray
    arc: np.ndarray
    width: np.ndarray
    peak: np.ndarray


def _arc_in_frame(shape, whole: _Piece) -> np.ndarray:
    """Fractions of the arc inside the frame: 0 where the line enters it, 1 where it leaves."""
    rows, cols = shape
    x, y = whole.line.T
    inside = (x >= 0) & (x <= cols - 1) & (y >= 0) & (y <= rows - 1)
    first, last = whole.arc[inside][[0, -1]]
    return (whole.arc - first) / (last - first)


def _broken(shape, whole: _Piece) -> list[_Piece]:
    """The stripe cut at BROKEN_BREAKS into segments shifted and widened as at depth steps."""
    tau = _arc_in_frame(shape, whole)
    cuts = np.interp(BROKEN_BREAKS, tau, whole.arc)
    half_gap = np.asarray(BROKEN_GAPS_PX) / 2
    starts = np.concatenate([[-np.inf], cuts + half_gap])
    stops = np.concatenate([cuts - half_gap, [np.inf]])
    pieces = []
    for start, stop, shift, width, gain in zip(
        starts, stops, BROKEN_SHIFTS_PX, BROKEN_WIDTHS_PX, BROKEN_GAINS, strict=True
    ):
        sel = (whole.arc >= start) & (whole.arc <= stop)
        line = whole.line[sel] + [0.0, shift]
        pieces.append(
            _Piece(line, whole.arc[sel], np.full(len(line), width), whole.peak[sel] * gain)
        )
    return pieces


def _ghost(shape, whole: _Piece, ratio: float) -> _Piece:
    """Inter-reflection of the GHOST_SPAN stretch: shifted, wider and `ratio` as bright."""
    tau = _arc_in_frame(shape, whole)
    sel = (tau >= GHOST_SPAN[0]) & (tau <= GHOST_SPAN[1])
    line = whole.line[sel] + [0.0, GHOST_SHIFT_PX]
    return _Piece(line, whole.arc[sel], whole.width[sel] * GHOST_WIDENING, whole.peak[sel] * ratio)


def _flare(shape, whole: _Piece) -> tuple[list[_Piece], np.ndarray]:
    """Radial streaks from the stripe at FLARE_AT, and the glare spot there (grey image)."""
    tau = _arc_in_frame(shape, whole)
    origin = whole.line[np.searchsorted(tau, FLARE_AT)]
    streaks = []
    for k, length in enumerate(FLARE_LENGTHS_PX):
        angle = np.deg2rad(20 + 45 * k)
        along = np.arange(8.0, 8.0 + length, TRUTH_STEP_PX)
        line = origin + along[:, None] * [np.cos(angle), np.sin(angle)]
        fade = FLARE_PEAK_GREY * (1 - (along - 8.0) / length)
        streaks.append(_Piece(line, along, np.full(len(line), FLARE_WIDTH_PX), fade))
    rows, cols = np.mgrid[0 : shape[0], 0 : shape[1]]
    d2 = (cols - origin[0]) ** 2 + (rows - origin[1]) ** 2
    return streaks, GLARE_PEAK_GREY * np.exp(-d2 / (2 * GLARE_SIGMA_PX**2))


def noise_bound_px(amplitude, background, width_px, *, read_noise, shot_noise, bits) -> np.ndarray:
    """Cramér–Rao bound of a Gaussian stripe's centre found with the adaptive scale [px].

    Parameters
    ----------
    amplitude, background, width_px : ndarray of shape (K,)
        Stripe peak above the background and the background [8-bit grey levels], and the
        1/e² full width w [px], at K points along the stripe.
    read_noise : float
        Read noise σ [8-bit grey levels].
    shot_noise : bool
        Whether shot noise of variance SHOT_GAIN per grey level is present.
    bits : int
        8 or 16: the quantisation step is 1 or 1/257 grey level.

    Notes
    -----
    A profile A·exp(−x²/(2s²)), s = w/4, in white noise σn has the 1-D bound
    (σn/A)·√(2s/√π) (Fisher information A²√π/(2s·σn²)). A centre found at σB = w/√3
    averages cross-sections over the kernel's equivalent length L = 2√π·σB along the stripe
    (a Gaussian window's (Σg)²/Σg² independent samples), so the bound is divided by √L.
    σn² = read² + SHOT_GAIN·(b + A·e^(−1/2)) + q²/12: the shot noise where the profile's
    slope, which carries the information, is steepest (x = ±s), and the quantisation q.
    """
    quantum = 1.0 if bits == 8 else 1.0 / 257
    variance = read_noise**2 + quantum**2 / 12
    if shot_noise:
        variance = variance + SHOT_GAIN * (background + amplitude * np.exp(-0.5))
    s = width_px / 4
    support_px = 2 * np.sqrt(np.pi) * width_px / np.sqrt(3)
    return np.sqrt(variance) / amplitude * np.sqrt(2 * s / np.sqrt(np.pi)) / np.sqrt(support_px)


def _background(case: StripeCase):
    """The scene behind the stripe (grey, 8-bit scale) and its bright lines."""
    if case.scene == "dark":
        return BACKGROUND_GREY, []
    scene = lit_scene(np.random.default_rng([case.seed, 1]), case.shape, case.scene, TRUTH_STEP_PX)
    return scene.grey, scene.lines


def _truth(
    case: StripeCase, pieces: list[_Piece], background, laser_mask, image
) -> SyntheticStripe:
    """Concatenate the pieces' samples with their segment numbers, end zones and bounds."""
    line = np.concatenate([p.line for p in pieces])
    width = np.concatenate([p.width for p in pieces])
    segment = np.repeat(np.arange(len(pieces)), [len(p.line) for p in pieces])
    end_zone = np.concatenate(
        [
            case.broken & ((p.arc - p.arc[0] < p.width / 2) | (p.arc[-1] - p.arc < p.width / 2))
            for p in pieces
        ]
    )
    under = np.broadcast_to(np.asarray(background, float), case.shape)
    rc = np.clip(line[:, ::-1].T, 0, np.array(case.shape)[:, None] - 1)
    amplitude = np.concatenate([p.peak for p in pieces]) * (1 + case.asymmetry) / 2
    bound = noise_bound_px(
        amplitude,
        map_coordinates(under, rc, order=1),
        width,
        read_noise=case.read_noise,
        shot_noise=case.shot_noise,
        bits=case.bits,
    )
    arc = np.concatenate([p.arc for p in pieces])
    return SyntheticStripe(case, image, line, arc, width, segment, end_zone, bound, laser_mask)


def make_stripe(case: StripeCase) -> SyntheticStripe:
    """Render the frame of `case` with its truth."""
    rng = np.random.default_rng(case.seed)
    line = wheel_line(case.shape)
    arc = np.concatenate([[0], np.cumsum(np.hypot(*np.diff(line, axis=0).T))])
    tau = arc / arc[-1]
    width = case.width_start_px + (case.width_end_px - case.width_start_px) * _smoothstep(
        (tau - 0.1) / 0.6
    )
    peak = np.full(len(line), case.peak_grey)
    if case.low_grey:
        # Two stretches at 25 % of the peak (worn, highly reflective tread; flange root).
        for centre in (0.45, 0.75):
            peak *= 1 - 0.75 * np.exp(-0.5 * ((tau - centre) / 0.03) ** 2)
    if case.saturation:
        peak *= 2.5
    whole = _Piece(line, arc, width, peak)
    pieces = _broken(case.shape, whole) if case.broken else [whole]
    background, scene_lines = _background(case)
    laser = np.zeros(case.shape)
    laser_mask = np.zeros(case.shape, bool)
    for piece in pieces:
        grey, lit = _render_line(
            case.shape,
            piece.line,
            piece.width,
            piece.peak,
            cut_ends=case.broken,
            left_gain=case.asymmetry,
        )
        laser += grey
        laser_mask |= lit
    if case.speckle:
        grain = gaussian_filter(
            np.random.default_rng([case.seed, 2]).normal(size=case.shape), SPECKLE_SIGMA_PX
        )
        laser *= np.clip(1 + case.speckle * grain / grain.std(), 0, None)
    image = background + laser
    extras = []
    if case.other_part:
        other = _other_part(case.shape, line)
        image += _render_line(
            case.shape, other, np.full(len(other), 7.0), np.full(len(other), 150.0)
        )[0]
        extras.append(other)
    if case.ghost_ratio:
        ghost = _ghost(case.shape, whole, case.ghost_ratio)
        image += _render_line(case.shape, ghost.line, ghost.width, ghost.peak)[0]
        extras.append(ghost.line)
    if case.flare:
        streaks, glare = _flare(case.shape, whole)
        image += glare
        for streak in streaks:
            image += _render_line(case.shape, streak.line, streak.width, streak.peak)[0]
            extras.append(streak.line)
    for bright in scene_lines:
        n = len(bright.xy)
        image += _render_line(
            case.shape, bright.xy, np.full(n, bright.width_px), np.full(n, bright.peak_grey)
        )[0]
        extras.append(bright.xy)
    if case.clutter:
        image += _clutter(rng, case.shape, line)
    if case.shot_noise:
        image = image + rng.normal(size=image.shape) * np.sqrt(SHOT_GAIN * image)
    image = image + rng.normal(scale=case.read_noise, size=image.shape)
    if case.bits == 16:
        frame = np.clip(np.rint(image * 257), 0, 65535).astype(np.uint16)
    else:
        frame = np.clip(np.rint(image), 0, 255).astype(np.uint8)
    stripe = _truth(case, pieces, background, laser_mask, frame)
    stripe.extras.extend(extras)
    return stripe
