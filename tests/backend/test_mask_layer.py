"""The mask layer shows the candidate centres the extraction rejected, in a grey of its own."""

from __future__ import annotations

import functools
import io

import cv2
import numpy as np

from backend.services.images import REJECTED_GREY, layer_png, mask_png
from backend.storage.artefacts import ARTEFACT_SUFFIX, load_artefacts, save_artefacts
from backend.storage.store import BlobStore
from pipeline import extract_centres
from tests.pipeline.stripe_images import StripeCase, make_stripe


@functools.cache
def _centres():
    """A stripe crossing lit plates' edges: the edges' candidates are rejected."""
    case = StripeCase("lit-edge-crossing", read_noise=3, shot_noise=True, scene="lit-crossing")
    return extract_centres(make_stripe(case).image)


def test_rejected_candidates_are_stored_and_drawn(tmp_path) -> None:
    centres = _centres()
    assert centres.rejected_x.size > 100
    store = BlobStore(tmp_path)
    artefacts = load_artefacts(store, save_artefacts(store, centres))
    np.testing.assert_array_equal(artefacts.rejected_xy[:, 0], centres.rejected_x)
    np.testing.assert_array_equal(artefacts.rejected_xy[:, 1], centres.rejected_y)
    png = layer_png(store, save_artefacts(store, centres), "mask", None).png
    image = cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_UNCHANGED)
    assert set(np.unique(image)) == {0, REJECTED_GREY, 255}
    rows = np.clip(np.rint(centres.rejected_y).astype(int), 0, image.shape[0] - 1)
    cols = np.clip(np.rint(centres.rejected_x).astype(int), 0, image.shape[1] - 1)
    assert (image[rows, cols] == REJECTED_GREY).all()
    accepted = image[np.rint(centres.y).astype(int), np.rint(centres.x).astype(int)]
    assert (accepted == 255).mean() > 0.9  # the stripe's own centres lie on the mask


def test_artefacts_stored_before_the_rejected_candidates_still_load(tmp_path) -> None:
    centres = _centres()
    store = BlobStore(tmp_path)
    old = io.BytesIO()
    mask = np.asarray(centres.mask, bool)
    np.savez_compressed(
        old,
        **{name: np.asarray(getattr(centres, name)) for name in ("x", "y", "nx", "ny")},
        sigma=np.asarray(centres.sigma),
        strength=np.asarray(centres.strength),
        mask_bits=np.packbits(mask, axis=None),
        mask_shape=np.array(mask.shape, np.int64),
    )
    artefacts = load_artefacts(store, store.put(old.getvalue(), ARTEFACT_SUFFIX))
    assert artefacts.rejected_xy.shape == (0, 2)
    image = cv2.imdecode(
        np.frombuffer(mask_png(artefacts.mask, artefacts.rejected_xy, None), np.uint8),
        cv2.IMREAD_UNCHANGED,
    )
    np.testing.assert_array_equal(image > 0, mask)
