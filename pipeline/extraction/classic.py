"""The classic baseline's stripe mask: median filter, Otsu threshold, largest components."""

from __future__ import annotations

import cv2
import numpy as np

from pipeline.extraction.blocks import all_blocks
from pipeline.extraction.closing import close_runs
from pipeline.extraction.components import label_runs, row_runs
from pipeline.extraction.segmentation import KEEP_FRACTION, MIN_COMPONENT_AREA_PX

MAX_FOREGROUND_FRACTION = 0.5
"""Otsu on a frame without a stripe splits the background itself; a foreground covering more
than this fraction of the frame is not a stripe."""

CLASSIC_MEDIAN_PX = 5
"""Median filter aperture of the classic baseline [px]."""


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
        8-connected components at least KEEP_FRACTION of the largest one's area, small holes
        closed (`closing.close_runs`); all False when the Otsu foreground covers most of the
        frame (no stripe).
    """
    smooth = cv2.medianBlur(to_uint8(image), CLASSIC_MEDIAN_PX)
    _, binary = cv2.threshold(smooth, 0, 1, cv2.THRESH_BINARY | cv2.THRESH_OTSU)
    if binary.mean() > MAX_FOREGROUND_FRACTION:
        return np.zeros(image.shape, dtype=bool)
    blocks = all_blocks(image.shape)
    runs = row_runs(binary.view(np.bool_), blocks)
    label, moments = label_runs(runs)
    area = moments[:, 0].copy()
    area[0] = 0
    if area.size < 2 or area.max() < MIN_COMPONENT_AREA_PX:
        return np.zeros(image.shape, dtype=bool)
    keep = area >= max(KEEP_FRACTION * area.max(), MIN_COMPONENT_AREA_PX)
    return close_runs(runs, keep[label], blocks, image.shape)
