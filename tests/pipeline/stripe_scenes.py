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

TEXTURE_CONTRAST = 0.3
"""Standard deviation of the reflectance texture relative to the mean reflectance."""

EDGE_BLUR_PX = 0.8
"""Optics blur of a plate outline: Gaussian σ of the step edge [px]."""

HIGHLIGHT_WIDTH_PX = 2.5
"""1/e² full width of an edge highlight [px]: narrower than the narrowest stripe (5 px)."""


@dataclass(frozen=True, eq=False)
class Scene:
    """A lit scene: its grey image (float, 8-bit scale) and the polylines of its highlights."""

    grey: np.ndarray
    highlights: list[np.ndarray]


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


LAYOUT_SHAPE = (400, 640)
"""Frame (rows, cols) the layouts are drawn for."""

LAYOUTS: dict[str, tuple[list[list[tuple[float, float]]], list[tuple[int, int]]]] = {
    # Plates beside the stripe, none crossing it: a rail head 35 px below the tread (its gauge
    # corner lit), a web plate left of the flange back, a lit patch inside the flange's curve
    # and a brake block above the tread, with highlights on the edges nearest the stripe.
    "lit": (
        [
            [(380, 352), (660, 352), (660, 420), (380, 420)],
            [(-20, 40), (60, 40), (60, 420), (-20, 420)],
            [(175, 160), (290, 160), (290, 330), (175, 330)],
            [(430, 170), (610, 170), (610, 265), (430, 265)],
        ],
        [(0, 0), (1, 1), (2, 3), (3, 2)],
    ),
    # Plate edges crossing the stripe: a slanted edge across the tread and a level one across
    # the flange back, each with its highlight; the stripe runs on the lit plates beyond them.
    "lit-crossing": (
        [
            [(470, 200), (660, 200), (660, 420), (520, 420)],
            [(-20, 250), (200, 250), (200, 420), (-20, 420)],
        ],
        [(0, 3), (1, 0)],
    ),
}
"""Plates of each lit scene: corners (x, y) [px], interior left of each edge in (x, y) (reading
order on the image: top left, top right, bottom right, bottom left), and the (plate, edge)
pairs that carry a highlight."""


def lit_scene(
    rng: np.random.Generator, shape: tuple[int, int], layout: str, step_px: float
) -> Scene:
    """Ambient-lit scene with plates, their bright step edges and thin edge highlights.

    Parameters
    ----------
    rng : numpy.random.Generator
        Source of the reflectance texture.
    shape : tuple of int
        Frame (rows, cols): LAYOUT_SHAPE, the frame the plates are placed for around the
        stripe of `stripe_images.wheel_line` (whose shape does not scale with the frame).
    layout : {"lit", "lit-crossing"}
        Plates and highlighted edges (LAYOUTS). Each plate is lit 2.2× the ambient level
        behind it; a highlight runs 1.5 px inside its edge, which goes from corner k to k + 1.
    step_px : float
        Spacing of the highlight polylines' samples [px].
    """
    if tuple(shape) != LAYOUT_SHAPE:
        raise ValueError(f"lit scenes are laid out for {LAYOUT_SHAPE} frames, got {shape}")
    corners, highlight_edges = LAYOUTS[layout]
    plates = [np.asarray(c, float) for c in corners]
    rows, cols = np.mgrid[0 : shape[0], 0 : shape[1]].astype(float)
    ambient = 26.0 + 14.0 * (cols / shape[1]) + 8.0 * np.sin(rows / shape[0] * np.pi)
    for plate in plates:
        ambient *= 1.0 + 1.2 * _polygon_inside(shape, plate)
    texture = gaussian_filter(rng.normal(size=shape), TEXTURE_SIGMA_PX, mode="reflect")
    texture *= TEXTURE_CONTRAST / texture.std()
    grey = np.clip(ambient * (1.0 + texture), *SCENE_GREY_RANGE)
    highlights = [
        _edge_samples(plates[p][e], np.roll(plates[p], -1, axis=0)[e], 1.5, step_px)
        for p, e in highlight_edges
    ]
    return Scene(grey, highlights)
