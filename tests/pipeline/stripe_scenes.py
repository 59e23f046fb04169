"""Lit scenes behind a synthetic stripe: what a wayside camera sees through its bandpass filter.

The scene is ambient light on textured parts with sharp outlines: an ambient level that
varies smoothly across the frame, lit plates (rail head, rim, a brake block) whose outlines
are bright step edges, a thin bright highlight along some of those edges (a lit chamfer or
gauge corner), and a multiplicative reflectance texture (rust, wear) correlated over a few
pixels. The grey of the scene stays within 20–100 on the 8-bit scale before the highlights.
None of it is laser light: the truth of a frame is its stripe alone (stripe_images).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import gaussian_filter
from scipy.special import erfc

SCENE_GREY_RANGE = (20.0, 100.0)
"""Grey of the lit scene before the edge highlights (8-bit levels)."""

TEXTURE_SIGMA_PX = 2.5
"""Correlation of the reflectance texture: the Gaussian σ its white noise is smoothed with [px]
(autocorrelation e^(-d²/(4σ²)), 1/e at d = 2σ = 5 px)."""

TEXTURE_CONTRAST = 0.15
"""Standard deviation of the reflectance texture relative to the mean reflectance: 2–3× the
real frames' 5–7 % (tests/pipeline/real_frames, fine detail beside the laser, noise included),
for rust and wear."""

EDGE_BLUR_PX = 0.8
"""Optics blur of a plate outline: Gaussian σ of the step edge [px]."""

HIGHLIGHT_WIDTH_PX = 2.5
"""1/e² full width of an edge highlight [px]: narrower than the narrowest stripe (5 px)."""

HIGHLIGHT_PEAK_GREY = 140.0
"""Peak of an edge highlight above the scene (8-bit levels)."""


@dataclass(frozen=True, eq=False)
class SceneLine:
    """A bright line of the scene: dense samples (x, y) [px], 1/e² width [px], peak [grey]."""

    xy: np.ndarray
    width_px: float
    peak_grey: float


@dataclass(frozen=True, eq=False)
class Scene:
    """A lit scene: its grey image (float, 8-bit scale) and its bright lines, to be drawn."""

    grey: np.ndarray
    lines: list[SceneLine]


@dataclass(frozen=True)
class Layout:
    """Plates (corners (x, y) [px], interior left of each edge in (x, y): reading order on the
    image, top left, top right, bottom right, bottom left), the (plate, edge) pairs that carry
    a highlight (edge k from corner k to k + 1), and glints: specular lines (start, end,
    1/e² width [px], peak above the scene [grey])."""

    plates: tuple[tuple[tuple[float, float], ...], ...]
    highlight_edges: tuple[tuple[int, int], ...]
    glints: tuple[tuple[tuple[float, float], tuple[float, float], float, float], ...] = ()


def _polygon_inside(shape, corners: np.ndarray) -> np.ndarray:
    """Blurred indicator of a convex polygon [0..1]; the interior lies left of each edge in (x, y).

    The signed distance to the nearest edge's half-plane (max over the edges) is exact near
    the edges, which is where the blur acts.
    """
    rows, cols = np.mgrid[0 : shape[0], 0 : shape[1]].astype(float)
    signed = np.full(shape, -np.inf)
    for a, b in zip(corners, np.roll(corners, -1, axis=0), strict=True):
        tangent = (b - a) / np.hypot(*(b - a))
        outward = np.array([tangent[1], -tangent[0]])
        signed = np.maximum(signed, (cols - a[0]) * outward[0] + (rows - a[1]) * outward[1])
    return 0.5 * erfc(signed / (np.sqrt(2) * EDGE_BLUR_PX))


def _edge_samples(a: np.ndarray, b: np.ndarray, inset_px: float, step_px: float) -> np.ndarray:
    """Dense points along the edge a→b moved `inset_px` to its left, into the polygon."""
    tangent = (b - a) / np.hypot(*(b - a))
    inward = np.array([-tangent[1], tangent[0]])
    n = int(np.hypot(*(b - a)) / step_px)
    return a + inward * inset_px + np.arange(n + 1)[:, None] * step_px * tangent


_BESIDE = (
    ((380, 352), (660, 352), (660, 420), (380, 420)),
    ((-20, 40), (60, 40), (60, 420), (-20, 420)),
    ((175, 160), (290, 160), (290, 330), (175, 330)),
    ((430, 170), (610, 170), (610, 265), (430, 265)),
)
_BESIDE_FULL = (
    ((850, 880), (1620, 880), (1620, 1220), (850, 1220)),
    ((-20, 150), (150, 150), (150, 1220), (-20, 1220)),
    ((400, 520), (500, 520), (500, 1000), (400, 1000)),
    ((800, 450), (1400, 450), (1400, 700), (800, 700)),
)
_BESIDE_EDGES = ((0, 0), (1, 1), (2, 3), (3, 2))

LAYOUTS = {
    # Plates beside the stripe, none crossing it: a rail head 35 px below the tread (its gauge
    # corner lit), a web plate left of the flange back, a lit patch inside the flange's curve
    # and a brake block above the tread, with highlights on the edges nearest the stripe.
    "lit": {(400, 640): Layout(_BESIDE, _BESIDE_EDGES)},
    # Plate edges crossing the stripe: a slanted edge across the tread and a level one across
    # the flange back, each with its highlight; the stripe runs on the lit plates beyond them.
    "lit-crossing": {
        (400, 640): Layout(
            (
                ((470, 200), (660, 200), (660, 420), (520, 420)),
                ((-20, 250), (200, 250), (200, 420), (-20, 420)),
            ),
            ((0, 3), (1, 0)),
        )
    },
    # The "lit" plates with specular lines as the real frames show them: a polished rod above
    # the tread (a brake rod, an axle-box bolt) with a bright narrow glint and a dimmer second
    # one, and the rail head's polished running band, longer than the stripe's pieces. Also
    # drawn for 1200×1600 frames (the speed benchmark), the plates as far from the stripe.
    "lit-specular": {
        (400, 640): Layout(
            (*_BESIDE, ((505, -20), (555, -20), (555, 150), (505, 150))),
            _BESIDE_EDGES,
            (
                ((520, -20), (520, 148), 8.0, 170.0),
                ((542, -20), (542, 148), 5.0, 90.0),
                ((380, 388), (660, 388), 12.0, 110.0),
            ),
        ),
        (1200, 1600): Layout(
            (*_BESIDE_FULL, ((1200, -20), (1300, -20), (1300, 380), (1200, 380))),
            _BESIDE_EDGES,
            (
                ((1230, -20), (1230, 378), 8.0, 170.0),
                ((1275, -20), (1275, 378), 5.0, 90.0),
                ((850, 920), (1620, 920), 12.0, 110.0),
            ),
        ),
    },
}
"""The lit scenes' layouts per frame shape (rows, cols), placed around the stripe of
`stripe_images.wheel_line` (whose shape does not scale with the frame)."""


def lit_scene(
    rng: np.random.Generator, shape: tuple[int, int], layout: str, step_px: float
) -> Scene:
    """Ambient-lit scene with plates, their bright step edges and thin edge highlights.

    Parameters
    ----------
    rng : numpy.random.Generator
        Source of the reflectance texture.
    shape : tuple of int
        Frame (rows, cols): one of the shapes the layout is drawn for (LAYOUTS).
    layout : {"lit", "lit-crossing", "lit-specular"}
        Plates, highlighted edges and glints (LAYOUTS). Each plate is lit 2.2× the ambient
        level behind it; a highlight runs 1.5 px inside its edge, HIGHLIGHT_WIDTH_PX wide and
        HIGHLIGHT_PEAK_GREY above the scene.
    step_px : float
        Spacing of the bright lines' samples [px].
    """
    if tuple(shape) not in LAYOUTS[layout]:
        raise ValueError(f"{layout!r} is laid out for {sorted(LAYOUTS[layout])}, got {shape}")
    plan = LAYOUTS[layout][tuple(shape)]
    plates = [np.asarray(c, float) for c in plan.plates]
    rows, cols = np.mgrid[0 : shape[0], 0 : shape[1]].astype(float)
    ambient = 26.0 + 14.0 * (cols / shape[1]) + 8.0 * np.sin(rows / shape[0] * np.pi)
    for plate in plates:
        ambient *= 1.0 + 1.2 * _polygon_inside(shape, plate)
    texture = gaussian_filter(rng.normal(size=shape), TEXTURE_SIGMA_PX, mode="reflect")
    texture *= TEXTURE_CONTRAST / texture.std()
    grey = np.clip(ambient * (1.0 + texture), *SCENE_GREY_RANGE)
    lines = [
        SceneLine(
            _edge_samples(plates[p][e], np.roll(plates[p], -1, axis=0)[e], 1.5, step_px),
            HIGHLIGHT_WIDTH_PX,
            HIGHLIGHT_PEAK_GREY,
        )
        for p, e in plan.highlight_edges
    ]
    for start, end, width_px, peak_grey in plan.glints:
        a, b = np.asarray(start, float), np.asarray(end, float)
        lines.append(SceneLine(_edge_samples(a, b, 0.0, step_px), width_px, peak_grey))
    return Scene(grey, lines)
