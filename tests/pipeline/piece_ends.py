"""Synthetic stripe pieces that end inside the frame, with exact truth, and their end scores.

A piece is a straight or curved (constant radius) centre line, wholly inside the frame, whose
peak A(τ) falls to 0 at both ends: over `fade_px` (a smoothstep ramp, a stripe fading where
the flange root is dim) or sharply (fade_px = 0: erfc with σ CUT_BLUR_PX, an occlusion).
Optionally the peak is modulated along the line, 1 + m·sin(2πτ/λ) (reflectance texture on
the stripe). Across the line the grey is Gaussian, `stripe_images._render_line`. The scene
behind it is dark (BACKGROUND_GREY) or lit: an ambient level with the lit scenes'
reflectance texture (stripe_scenes). Scores: each centre's signed distance across the true
line and its normal's tilt against the true normal, by how many centres it lies from its
polyline's nearer end.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import gaussian_filter
from scipy.spatial import cKDTree
from scipy.special import erfc

from tests.pipeline.stripe_images import (
    BACKGROUND_GREY,
    CUT_BLUR_PX,
    SHOT_GAIN,
    _render_line,
    _smoothstep,
    _turtle,
    project_on_line,
)
from tests.pipeline.stripe_scenes import TEXTURE_CONTRAST, TEXTURE_SIGMA_PX

LIT_GREY = 45.0
"""Ambient level of the lit scene behind a piece (8-bit levels), textured as stripe_scenes."""

END_BINS = (0, 1, 2, 4, 8, 16)
"""Centres from a polyline's nearer end at which the errors are reported (16: ≥ 16)."""


@dataclass(frozen=True)
class PieceCase:
    """Recipe of one frame holding one piece; lengths in px, widths 1/e² full widths."""

    name: str
    length_px: float = 160.0
    radius_px: float = 0.0
    heading_deg: float = 20.0
    width_px: float = 9.0
    peak_grey: float = 150.0
    fade_px: float = 6.0
    texture_period_px: float = 0.0
    texture_depth: float = 0.0
    scene: str = "dark"
    read_noise: float = 0.0
    shot_noise: bool = False
    seed: int = 0
    shape: tuple[int, int] = (240, 320)
    """`radius_px` 0 for a straight piece, else the radius of its arc (turning clockwise on
    the image); `fade_px` 0 for a sharp end; `scene` "dark" or "lit"."""


@dataclass(frozen=True, eq=False)
class Piece:
    """A rendered piece: frame, dense truth line (x, y) and its arc length [px]."""

    case: PieceCase
    image: np.ndarray
    line_xy: np.ndarray
    arc_px: np.ndarray


def piece_line(case: PieceCase) -> np.ndarray:
    """Dense truth line of `case`, centred in the frame."""
    if case.radius_px:
        moves = [(case.radius_px, np.rad2deg(case.length_px / case.radius_px))]
    else:
        moves = [(case.length_px, 0)]
    line = _turtle((0.0, 0.0), case.heading_deg, moves)
    middle = (line.min(axis=0) + line.max(axis=0)) / 2
    rows, cols = case.shape
    return line - middle + [cols / 2 + 0.3, rows / 2 + 0.2]


def piece_peak(case: PieceCase, arc: np.ndarray) -> np.ndarray:
    """Peak above the scene along the arc [8-bit grey]: the end fades and the texture."""
    length = arc[-1]
    if case.fade_px:
        fade = _smoothstep(arc / case.fade_px) * _smoothstep((length - arc) / case.fade_px)
    else:
        blur = np.sqrt(2) * CUT_BLUR_PX
        fade = 0.5 * erfc(-arc / blur) * 0.5 * erfc(-(length - arc) / blur)
    texture = 1.0
    if case.texture_period_px:
        texture = 1 + case.texture_depth * np.sin(2 * np.pi * arc / case.texture_period_px)
    return case.peak_grey * fade * texture


def make_piece(case: PieceCase) -> Piece:
    """Render the frame of `case` (uint8) with its truth."""
    rng = np.random.default_rng(case.seed)
    line = piece_line(case)
    arc = np.concatenate([[0], np.cumsum(np.hypot(*np.diff(line, axis=0).T))])
    width = np.full(len(line), case.width_px)
    laser, _ = _render_line(case.shape, line, width, piece_peak(case, arc))
    if case.scene == "lit":
        grain = gaussian_filter(rng.normal(size=case.shape), TEXTURE_SIGMA_PX)
        scene = LIT_GREY * (1 + TEXTURE_CONTRAST * grain / grain.std())
    else:
        scene = np.full(case.shape, BACKGROUND_GREY)
    image = scene + laser
    if case.shot_noise:
        image = image + rng.normal(size=image.shape) * np.sqrt(SHOT_GAIN * image)
    image = image + rng.normal(scale=case.read_noise, size=image.shape)
    frame = np.clip(np.rint(image), 0, 255).astype(np.uint8)
    return Piece(case, frame, line, arc)


@dataclass(frozen=True, eq=False)
class EndScore:
    """Per centre of a piece: signed distance across the true line [px] (+: right of its
    direction on the image), |tilt| of the normal against the true normal [deg], centres from
    its polyline's nearer end, and whether its foot lies past the truth's ends."""

    across_px: np.ndarray
    tilt_deg: np.ndarray
    from_end: np.ndarray
    past_end: np.ndarray

    def median_abs(self, ends: int, *, upto: int | None = None) -> float:
        """Median |across| of the centres `ends`…`upto` (default: that one bin) from an end."""
        hi = ends if upto is None else upto
        sel = (self.from_end >= ends) & (self.from_end <= hi)
        return float(np.median(np.abs(self.across_px[sel]))) if sel.any() else np.nan


def score_piece(piece: Piece, x, y, nx, ny, polylines) -> EndScore:
    """Score centres (x, y) with unit normals on their polylines against the piece's truth.

    Centres whose foot is past either end of the truth are measured to the end's tangent
    line (as `project_on_line` clips them to the end sample, their distance is Euclidean;
    the across component is the one that matters here).
    """
    line, arc = piece.line_xy, piece.arc_px
    order = np.concatenate(polylines) if polylines else np.zeros(0, np.int64)
    from_end = (
        np.concatenate(
            [np.minimum(np.arange(c.size), c.size - 1 - np.arange(c.size)) for c in polylines]
        )
        if polylines
        else np.zeros(0, np.int64)
    )
    xy = np.column_stack([x[order], y[order]])
    foot = project_on_line(cKDTree(line), line, arc, xy)
    k = np.clip(foot.index, 1, len(line) - 2)
    tangent = line[k + 1] - line[k - 1]
    tangent /= np.hypot(*tangent.T)[:, None]
    normal = np.column_stack([-tangent[:, 1], tangent[:, 0]])
    nearest = line[foot.index]
    across = ((xy - nearest) * normal).sum(axis=1)
    cos = np.abs(nx[order] * normal[:, 0] + ny[order] * normal[:, 1])
    tilt = np.rad2deg(np.arccos(np.clip(cos, 0, 1)))
    past = (foot.arc_px <= arc[0]) | (foot.arc_px >= arc[-1])
    return EndScore(across, tilt, from_end, past)
