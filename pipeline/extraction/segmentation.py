"""Stripe segmentation: ridge-response masks (adaptive) and median + Otsu masks (classic)."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from pipeline.extraction.ridges import RIDGE_THRESHOLD
from pipeline.jit import kernel

MIN_COMPONENT_AREA_PX = 40
"""Components smaller than this [px²] are noise or stray spots, never a stripe."""

MIN_ELONGATION = 3.0
"""Least elongation L²/A of a stripe component (L: length of the uniform bar with the same
second moment, A: area). A disc or a square has about 1, an L:w bar L/w."""

KEEP_FRACTION = 0.3
"""Components at least this fraction of the main stripe's length (area for the classic
baseline) are kept as parts of the stripe; shorter elongated ones (another part's stripe,
reflections) are dropped."""

MAX_FOREGROUND_FRACTION = 0.5
"""Otsu on a frame without a stripe splits the background itself; a foreground covering more
than this fraction of the frame is not a stripe."""

CLASSIC_MEDIAN_PX = 5
"""Median filter aperture of the classic baseline [px]."""

CLOSING_PX = 5
"""Diameter of the disc whose closing fills small holes and notches of the mask [px]."""


@dataclass(frozen=True, slots=True, eq=False)
class ComponentShapes:
    """Shape figures of the labelled components 1..K (index 0 is the background)."""

    area_px: np.ndarray
    length_px: np.ndarray
    elongation: np.ndarray


def shapes_from_moments(
    area: np.ndarray,
    sum_r: np.ndarray,
    sum_c: np.ndarray,
    sum_rr: np.ndarray,
    sum_cc: np.ndarray,
    sum_rc: np.ndarray,
) -> ComponentShapes:
    """Area, equivalent bar length and elongation from each component's pixel moments.

    Notes
    -----
    With λmax the largest eigenvalue of the pixel-coordinate covariance, L = √(12·λmax) is
    the length of a uniform bar with that variance, and the elongation is L²/A.
    """
    safe = np.maximum(area, 1)
    mr, mc = sum_r / safe, sum_c / safe
    vrr = sum_rr / safe - mr**2
    vcc = sum_cc / safe - mc**2
    vrc = sum_rc / safe - mr * mc
    lam_max = 0.5 * (vrr + vcc) + np.sqrt(0.25 * (vrr - vcc) ** 2 + vrc**2)
    length = np.sqrt(12 * np.maximum(lam_max, 0))
    return ComponentShapes(area_px=area, length_px=length, elongation=length**2 / safe)


@kernel
def _label_moments(labels, count):
    """Area and the sums of r, c, r², c², r·c of each label 0..count − 1, raster order:
    (count, 6) float64."""
    moments = np.zeros((count, 6))
    for r in range(labels.shape[0]):
        for c in range(labels.shape[1]):
            k = labels[r, c]
            if k:
                moments[k, 0] += 1
                moments[k, 1] += r
                moments[k, 2] += c
                moments[k, 3] += r * r
                moments[k, 4] += c * c
                moments[k, 5] += r * c
    return moments


def component_shapes(labels: np.ndarray, count: int) -> ComponentShapes:
    """Area, equivalent bar length and elongation of each labelled component."""
    return shapes_from_moments(*_label_moments(labels, count).T)


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


def close_holes(mask: np.ndarray) -> np.ndarray:
    """Fill small holes and notches of the mask (bool, or uint8 0/1) with a morphological
    closing (paper §3.3); returns a bool mask.

    A closing, not a flood fill of every enclosed region: the background enclosed by a bent
    stripe is not part of it.
    """
    disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (CLOSING_PX, CLOSING_PX))
    # 0/1 bytes either way: a bool mask is read, and the result returned, without copies.
    ones = mask.view(np.uint8) if mask.dtype == np.bool_ else mask
    return cv2.morphologyEx(ones, cv2.MORPH_CLOSE, disc).view(np.bool_)


def segment_ridges(response: np.ndarray) -> np.ndarray:
    """Stripe mask from the multi-scale ridge response: threshold, components, selection.

    Parameters
    ----------
    response : ndarray of shape (M, N), float32
        Multi-scale ridge response V (see `pipeline.extraction.ridges.ridge_response`).

    Returns
    -------
    ndarray of shape (M, N), bool
        The stripe mask; all False when no component qualifies.

    Notes
    -----
    V > RIDGE_THRESHOLD, 8-connected components, the stripe's among them
    (`stripe_components`); small holes are then closed.
    """
    binary = (response > RIDGE_THRESHOLD).astype(np.uint8)
    count, labels = cv2.connectedComponents(binary, connectivity=8, ltype=cv2.CV_32S)
    keep = stripe_components(component_shapes(labels, count))
    if not keep.any():
        return np.zeros(response.shape, dtype=bool)
    return close_holes(keep[labels])


def to_uint8(image: np.ndarray) -> np.ndarray:
    """8-bit view of a frame for grey-level thresholding (uint16 keeps its top 8 bits)."""
    if image.dtype == np.uint8:
        return image
    if image.dtype == np.uint16:
        return (image >> 8).astype(np.uint8)
    return np.clip(np.rint(image), 0, 255).astype(np.uint8)


def segment_classic(image: np.ndarray) -> np.ndarray:
    """Classic baseline mask: median filter, Otsu threshold, largest connected components.

    Parameters
    ----------
    image : ndarray of shape (M, N), uint8, uint16 or float on the 8-bit grey scale
        Grey frame.

    Returns
    -------
    ndarray of shape (M, N), bool
        Components at least KEEP_FRACTION of the largest one's area, small holes closed;
        all False when the Otsu foreground covers most of the frame (no stripe).
    """
    smooth = cv2.medianBlur(to_uint8(image), CLASSIC_MEDIAN_PX)
    _, binary = cv2.threshold(smooth, 0, 1, cv2.THRESH_BINARY | cv2.THRESH_OTSU)
    if binary.mean() > MAX_FOREGROUND_FRACTION:
        return np.zeros(image.shape, dtype=bool)
    count, labels, stats, _ = cv2.connectedComponentsWithStats(binary, connectivity=8)
    area = stats[:, cv2.CC_STAT_AREA].astype(np.float64)
    area[0] = 0
    if count < 2 or area.max() < MIN_COMPONENT_AREA_PX:
        return np.zeros(image.shape, dtype=bool)
    keep = area >= max(KEEP_FRACTION * area.max(), MIN_COMPONENT_AREA_PX)
    return close_holes(keep[labels])
