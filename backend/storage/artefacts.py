"""Per-frame measurement artefacts (centres, stripe mask, σ map, rejected candidates) as
compressed .npz blobs.

One blob per (measurement, sensor, frame) in the content-addressed store: the arrays of a
`pipeline.Centres` needed to review the extraction, without re-running it.
"""

from __future__ import annotations

import io
from dataclasses import dataclass

import numpy as np

from backend.storage.store import BlobStore
from pipeline import Centres

ARTEFACT_SUFFIX = ".npz"
POINT_FIELDS = ("x", "y", "nx", "ny", "sigma", "strength")


@dataclass(frozen=True, slots=True, eq=False)
class FrameArtefacts:
    """What is kept of one frame's extraction.

    Attributes
    ----------
    points : dict of str to ndarray of shape (K,), float64
        x, y [px], nx, ny (unit normal), sigma [px], strength [grey levels].
    mask : ndarray of shape (M, N), bool
        Stripe mask.
    sigma_map : ndarray of shape (M, N), float32, or None
        σB per mask pixel [px], 0 elsewhere; None for fixed-σ methods.
    rejected_xy : ndarray of shape (R, 2), float64
        Candidate centres the extraction rejected (x, y [px], `Centres.rejected_x/y`);
        empty for artefacts stored before they were kept.
    """

    points: dict[str, np.ndarray]
    mask: np.ndarray
    sigma_map: np.ndarray | None
    rejected_xy: np.ndarray


def save_artefacts(store: BlobStore, centres: Centres) -> str:
    """Store the artefacts of one frame's centres; returns the blob's sha256."""
    arrays: dict[str, np.ndarray] = {
        name: np.asarray(getattr(centres, name), np.float64) for name in POINT_FIELDS
    }
    mask = np.asarray(centres.mask, bool)
    arrays["mask_bits"] = np.packbits(mask, axis=None)
    arrays["mask_shape"] = np.array(mask.shape, np.int64)
    if centres.sigma_map is not None:
        arrays["sigma_map"] = np.asarray(centres.sigma_map, np.float32)
    arrays["rejected_xy"] = np.stack([centres.rejected_x, centres.rejected_y], axis=1)
    buffer = io.BytesIO()
    np.savez_compressed(buffer, **arrays)  # type: ignore[arg-type]
    return store.put(buffer.getvalue(), ARTEFACT_SUFFIX)


def load_artefacts(store: BlobStore, sha256: str) -> FrameArtefacts:
    """Read back what `save_artefacts` stored."""
    with np.load(io.BytesIO(store.get(sha256, ARTEFACT_SUFFIX))) as data:
        shape = tuple(int(v) for v in data["mask_shape"])
        mask = np.unpackbits(data["mask_bits"], count=shape[0] * shape[1]).astype(bool)
        sigma_map = data["sigma_map"] if "sigma_map" in data.files else None
        rejected = data["rejected_xy"] if "rejected_xy" in data.files else np.zeros((0, 2))
        return FrameArtefacts(
            points={name: data[name] for name in POINT_FIELDS},
            mask=mask.reshape(shape),
            sigma_map=sigma_map,
            rejected_xy=rejected,
        )
