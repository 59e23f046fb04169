"""Which components of a ridge-response mask are the stripe: size, elongation and length."""

from __future__ import annotations

import numpy as np

from pipeline.extraction.components import ComponentShapes

MIN_COMPONENT_AREA_PX = 40
"""Components smaller than this [px²] are noise or stray spots, never a stripe."""

MIN_ELONGATION = 3.0
"""Least elongation L²/A of a stripe component (L: length of the uniform bar with the same
second moment, A: area). A disc or a square has about 1, an L:w bar L/w."""

KEEP_FRACTION = 0.3
"""Components at least this fraction of the main stripe's length (area for the classic
baseline) are kept as parts of the stripe; shorter elongated ones (another part's stripe,
reflections) are dropped."""


def stripe_components(shapes: ComponentShapes) -> np.ndarray:
    """Which components (index 0: background, never) are parts of the stripe (bool (K,)).

    Candidates have area ≥ MIN_COMPONENT_AREA_PX and elongation ≥ MIN_ELONGATION; the longest
    is the stripe, and further candidates at least KEEP_FRACTION of its length are its pieces.
    """
    candidate = (shapes.area_px >= MIN_COMPONENT_AREA_PX) & (shapes.elongation >= MIN_ELONGATION)
    candidate[0] = False
    if not candidate.any():
        return candidate
    main_length = shapes.length_px[candidate].max()
    return candidate & (shapes.length_px >= KEEP_FRACTION * main_length)
