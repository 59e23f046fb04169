"""PNG renderings for the browser: frames, stripe masks (with the rejected candidates) and
coloured σ maps (downscaled)."""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import cv2
import numpy as np
from matplotlib import colormaps

from backend.errors import NotFoundError
from backend.storage.artefacts import FrameArtefacts, load_artefacts
from backend.storage.store import BlobStore
from db.models import MeasurementFrame
from pipeline import Centres
from pipeline.archive.pass_archive import decode_frame
from pipeline.extraction.adaptive import stripe_scales

SIGMA_COLORMAP = "viridis"
WIDTH_RANGE_PX = (5.0, 21.0)
"""The stripe widths the service measures with (measure_wheel's defaults) [px]."""
SIGMA_SCALES_PX = stripe_scales(*WIDTH_RANGE_PX)
"""σ1, σ2, σ3 [px]."""
SIGMA_RANGE_PX = (SIGMA_SCALES_PX[0], SIGMA_SCALES_PX[2])
"""Every σ map is coloured over [σ1, σ3], so one colour is one σ in every frame (a
per-frame range coloured 7.5 px yellow in one frame and teal in the next)."""

REJECTED_GREY = 96
"""Grey of the rejected candidate centres in the mask PNG (the stripe is 255, the rest 0):
below half grey, so a reader that knows only the mask leaves them out."""


def _downscale(image: np.ndarray, max_width_px: int | None, *, nearest: bool) -> np.ndarray:
    if max_width_px is None or image.shape[1] <= max_width_px:
        return image
    height_px = max(1, round(image.shape[0] * max_width_px / image.shape[1]))
    interpolation = cv2.INTER_NEAREST if nearest else cv2.INTER_AREA
    return cv2.resize(image, (max_width_px, height_px), interpolation=interpolation)


def encode_png(image: np.ndarray) -> bytes:
    ok, buffer = cv2.imencode(".png", image, [cv2.IMWRITE_PNG_COMPRESSION, 3])
    if not ok:
        raise ValueError(
            f"image of shape {image.shape} and dtype {image.dtype} is not PNG-encodable"
        )
    return buffer.tobytes()


def frame_png(png_bytes: bytes, max_width_px: int | None) -> bytes:
    """A stored frame, downscaled to `max_width_px` when wider (grey levels kept)."""
    if max_width_px is None:
        return png_bytes
    image = decode_frame(png_bytes, "stored frame")
    return encode_png(_downscale(image, max_width_px, nearest=False))


def mask_png(mask: np.ndarray, rejected_xy: np.ndarray, max_width_px: int | None) -> bytes:
    """The stripe mask as an 8-bit PNG: 255 on the stripe, REJECTED_GREY on a 3×3 square
    around each rejected candidate centre (x, y [px]), 0 elsewhere."""
    image = np.where(mask, np.uint8(255), np.uint8(0))  # uint8 from the start, not int64
    cols = np.clip(np.rint(rejected_xy[:, 0]).astype(np.int64), 0, mask.shape[1] - 1)
    rows = np.clip(np.rint(rejected_xy[:, 1]).astype(np.int64), 0, mask.shape[0] - 1)
    spots = np.zeros(mask.shape, np.uint8)
    spots[rows, cols] = 1
    image[cv2.dilate(spots, np.ones((3, 3), np.uint8)) > 0] = REJECTED_GREY
    return encode_png(_downscale(image, max_width_px, nearest=True))


def sigma_png(
    sigma_map: np.ndarray, sigma_min_px: float, sigma_max_px: float, max_width_px: int | None
) -> bytes:
    """σ map coloured with `SIGMA_COLORMAP` over [sigma_min_px, sigma_max_px]; RGBA with
    transparent pixels where no scale was chosen (σ = 0), so it overlays the frame."""
    small = _downscale(sigma_map, max_width_px, nearest=True)
    span = max(sigma_max_px - sigma_min_px, 1e-9)
    unit = np.clip((small - sigma_min_px) / span, 0.0, 1.0)
    # bytes=True: the colormap's table scaled to uint8 once, then indexed (the same bytes
    # as scaling a float64 RGBA frame, without making one)
    rgba = colormaps[SIGMA_COLORMAP](unit, bytes=True)
    rgba[..., 3] = np.where(small > 0, 255, 0)
    return encode_png(cv2.cvtColor(rgba, cv2.COLOR_RGBA2BGRA))


@lru_cache(maxsize=4)
def cached_artefacts(store: BlobStore, sha256: str) -> FrameArtefacts:
    """Artefacts of a frame, kept decompressed for the next layer requests (immutable)."""
    return load_artefacts(store, sha256)


@dataclass(frozen=True, slots=True)
class LayerPng:
    """A rendered layer and, for σ maps, its colour scale [px]."""

    png: bytes
    sigma_min_px: float
    sigma_max_px: float


@lru_cache(maxsize=64)
def layer_png(store: BlobStore, sha256: str, layer: str, max_width_px: int | None) -> LayerPng:
    """The "mask" or "sigma" layer of a frame's artefacts as PNG (rendered once, cached)."""
    artefacts = cached_artefacts(store, sha256)
    if layer == "mask":
        return LayerPng(mask_png(artefacts.mask, artefacts.rejected_xy, max_width_px), 0.0, 0.0)
    if artefacts.sigma_map is None:
        raise ValueError(f"artefacts {sha256[:12]}… have no σ map (a fixed-σ method)")
    low, high = SIGMA_RANGE_PX
    return LayerPng(sigma_png(artefacts.sigma_map, low, high, max_width_px), low, high)


def sigma_map_of(artefacts: FrameArtefacts, method: str) -> np.ndarray:
    """The σ map of a frame's artefacts [px]; NotFoundError for a fixed-σ method."""
    if artefacts.sigma_map is None:
        raise NotFoundError(f"the {method} method uses one fixed σ and has no σ map")
    return artefacts.sigma_map


def mask_layer(store: BlobStore, row: MeasurementFrame, max_width_px: int | None) -> bytes:
    """The stripe mask PNG of one stored extraction: the one rendered at measurement time
    at full size, else rendered now (and cached)."""
    if max_width_px is None and row.mask_png_sha256 is not None:
        return store.get(row.mask_png_sha256, ".png")
    return layer_png(store, row.artefact_sha256, "mask", max_width_px).png


def sigma_layer(
    store: BlobStore, row: MeasurementFrame, method: str, max_width_px: int | None
) -> LayerPng:
    """The coloured σ map PNG of one stored extraction and its colour scale, as
    `mask_layer`; NotFoundError for a fixed-σ method."""
    if max_width_px is None and row.sigma_png_sha256 is not None:
        return LayerPng(
            store.get(row.sigma_png_sha256, ".png"),
            row.sigma_min_px or 0.0,
            row.sigma_max_px or 0.0,
        )
    sigma_map_of(cached_artefacts(store, row.artefact_sha256), method)
    return layer_png(store, row.artefact_sha256, "sigma", max_width_px)


def prerender_layers(store: BlobStore, centres: Centres) -> dict[str, str | float | None]:
    """Render a frame's full-size mask and coloured σ map once, in the worker, as blobs.

    Returns the MeasurementFrame fields: mask_png_sha256, sigma_png_sha256, sigma_min_px,
    sigma_max_px (the σ ones None for fixed-σ methods).
    """
    layers: dict[str, str | float | None] = {
        "mask_png_sha256": store.put(
            mask_png(centres.mask, np.stack([centres.rejected_x, centres.rejected_y], 1), None),
            ".png",
        ),
        "sigma_png_sha256": None,
        "sigma_min_px": None,
        "sigma_max_px": None,
    }
    if centres.sigma_map is not None:
        low, high = SIGMA_RANGE_PX
        layers["sigma_png_sha256"] = store.put(
            sigma_png(centres.sigma_map, low, high, None), ".png"
        )
        layers["sigma_min_px"], layers["sigma_max_px"] = low, high
    return layers
