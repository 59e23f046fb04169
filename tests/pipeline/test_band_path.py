"""The band path (the camera-rate default) against the full-frame reference path."""

from __future__ import annotations

import functools
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import pipeline.extraction.band_analysis as band_analysis
import pipeline.extraction.centres as centres_module
from pipeline import extract_centres
from pipeline.simulation.field import FIELD_MODES
from pipeline.simulation.passes import build_station, build_train, pass_start_time, simulate_pass
from tests.pipeline.real_frame_truth import REAL_FRAME_NAMES, load_real_frame
from tests.pipeline.stripe_images import StripeCase, make_stripe
from tests.pipeline.test_centres_accuracy import UNIFORM, VARYING
from tests.pipeline.test_harsh_cases import HARSH
from tests.pipeline.test_steger import straight_stripe

FULL_FRAME = (1200, 1600)
CASES = [
    *UNIFORM,
    *VARYING,
    replace(StripeCase("frame-clean"), shape=FULL_FRAME),
    replace(
        StripeCase("frame-clutter", read_noise=3, shot_noise=True, clutter=True, other_part=True),
        shape=FULL_FRAME,
    ),
]


def _assert_same_points(band, full) -> None:
    """The same centres, bit for bit: inside the band both paths run the same kernels."""
    for name in ("x", "y", "nx", "ny", "sigma", "strength", "width_px"):
        np.testing.assert_array_equal(getattr(band, name), getattr(full, name), err_msg=name)
    assert [p.tolist() for p in band.polylines] == [p.tolist() for p in full.polylines]


def _assert_band_is_full(image: np.ndarray, **options) -> str:
    """Band path and full frame give the same mask, σ map and centres on `image` (with the
    extraction `options`); returns the band path's `path`."""
    band = extract_centres(image, **options)
    full = extract_centres(image, full_frame=True, **options)
    assert full.path == "full"
    np.testing.assert_array_equal(band.mask, full.mask)
    np.testing.assert_array_equal(band.sigma_map, full.sigma_map)
    _assert_same_points(band, full)
    return band.path


@functools.cache
def _both(case: StripeCase, method: str):
    image = make_stripe(case).image
    return extract_centres(image, method), extract_centres(image, method, full_frame=True)


@pytest.mark.parametrize("method", ["adaptive", "steger"])
@pytest.mark.parametrize("case", CASES, ids=lambda c: c.name)
def test_band_path_gives_the_full_frame_result(case: StripeCase, method: str) -> None:
    band, full = _both(case, method)
    assert band.path == "band"
    assert full.path == "full"
    np.testing.assert_array_equal(band.mask, full.mask)
    _assert_same_points(band, full)
    np.testing.assert_array_equal(band.sigma, full.sigma)
    if method == "adaptive":
        np.testing.assert_array_equal(band.sigma_map, full.sigma_map)


def test_a_frame_without_stripe_has_no_centres_on_either_path() -> None:
    rng = np.random.default_rng(3)
    image = np.clip(12 + rng.normal(0, 3, FULL_FRAME), 0, 255).astype(np.uint8)
    band = extract_centres(image)
    assert band.path == "band"
    assert len(band) == 0 and not band.mask.any()
    assert len(extract_centres(image, full_frame=True)) == 0


def test_a_frame_the_band_cannot_cover_falls_back_to_the_full_frame() -> None:
    # Bright ridges everywhere (a grating): the band would be most of the frame.
    rows = np.arange(FULL_FRAME[0], dtype=np.float64)[:, None]
    image = np.broadcast_to(12 + 150 * (np.sin(rows / 9.0) > 0.6), FULL_FRAME).astype(np.uint8)
    band = extract_centres(image)
    full = extract_centres(image, full_frame=True)
    assert band.path == "fallback"
    np.testing.assert_array_equal(band.x, full.x)


def test_classic_always_takes_the_full_frame() -> None:
    assert extract_centres(make_stripe(UNIFORM[1]).image, "classic").path == "full"


@settings(max_examples=15, deadline=None)
@given(
    angle_deg=st.floats(-80, 80),
    offset_px=st.floats(-20, 20),
    width_px=st.floats(5, 21),
)
def test_band_path_equals_full_frame_on_straight_stripes(angle_deg, offset_px, width_px) -> None:
    image = straight_stripe(angle_deg, offset_px, width_px, shape=(240, 320))
    band = extract_centres(image)
    full = extract_centres(image, full_frame=True)
    assert band.path == "band"
    np.testing.assert_array_equal(band.mask, full.mask)
    _assert_same_points(band, full)


def _bands_tried(monkeypatch) -> list:
    """Record every band the band path locates from now on (a spy on `locate_band`)."""
    tried = []
    real = band_analysis.locate_band

    def spy(*args, **kwargs):
        tried.append(real(*args, **kwargs))
        return tried[-1]

    monkeypatch.setattr(band_analysis, "locate_band", spy)
    return tried


def test_stray_spots_are_left_out_of_the_band(monkeypatch) -> None:
    _, full = _both(CASES[-1], "adaptive")  # frame-clutter
    tried = _bands_tried(monkeypatch)
    again = extract_centres(make_stripe(CASES[-1]).image)
    assert len(tried) == 1 and tried[0].left_out_px > 0
    np.testing.assert_array_equal(again.mask, full.mask)
    np.testing.assert_array_equal(again.sigma_map, full.sigma_map)


def test_a_short_stripe_left_out_beside_a_faint_long_ridge_is_taken_back(monkeypatch) -> None:
    # The long faint ridge makes the largest seed region but no stripe (V < 0.5); the 75 px
    # stripe's region looks small beside it, and the band first leaves it out.
    rows, cols = np.mgrid[0:1200, 0:1600].astype(np.float64)
    image = 12 + 8 * np.exp(-2 * ((rows - 300) / 6) ** 2)
    image += 150 * np.exp(-2 * ((rows - 800) / 4.5) ** 2) * ((cols > 700) & (cols < 775))
    image = image.astype(np.uint8)
    tried = _bands_tried(monkeypatch)
    band = extract_centres(image)
    full = extract_centres(image, full_frame=True)
    assert [b.left_out_px > 0 for b in tried] == [True, False]
    assert band.path == "band" and len(full) > 50
    np.testing.assert_array_equal(band.mask, full.mask)
    _assert_same_points(band, full)


def _stripe_with_faint_branch(branch_px: float) -> np.ndarray:
    """A stripe (w 9 px, peak 40) and, off its side, a fainter thin line (w 3 px, peak 16)
    of `branch_px`: the finest scale sees the line (V > 0.5), the
    coarsest hardly (V < 0.1), so the band located on the coarsest scale ends where the
    line goes on."""
    rows, cols = np.mgrid[0:600, 0:800].astype(np.float64)
    image = 12 + 40 * np.exp(-8 * ((rows - 300) / 9) ** 2) * ((cols > 100) & (cols < 700))
    image += 16 * np.exp(-8 * ((cols - 400) / 3) ** 2) * ((rows > 300) & (rows < 300 + branch_px))
    return np.rint(image).astype(np.uint8)


@pytest.mark.parametrize(
    ("branch_px", "path"), [(25, "band"), (35, "wide band"), (100, "fallback")]
)
def test_a_piece_the_band_cuts_takes_the_wider_band_or_the_whole_frame(branch_px, path) -> None:
    image = _stripe_with_faint_branch(branch_px)
    band = extract_centres(image)
    full = extract_centres(image, full_frame=True)
    assert band.path == path
    assert len(full) > 500
    np.testing.assert_array_equal(band.mask, full.mask)
    _assert_same_points(band, full)


def _fallback_reasons(monkeypatch) -> list[str]:
    """Record why every frame analysed from now on took the whole frame (a spy on
    `analyse_band`; "" for a frame that kept its band)."""
    reasons = []
    real = centres_module.analyse_band

    def spy(*args, **kwargs):
        analysis = real(*args, **kwargs)
        reasons.append(analysis.reason)
        return analysis

    monkeypatch.setattr(centres_module, "analyse_band", spy)
    return reasons


def test_a_stripe_component_reaching_the_band_edge_takes_the_whole_frame(monkeypatch) -> None:
    # The 100 px branch leaves the wider band too: the fallback for this reason, not
    # because the band would cover most of the frame.
    reasons = _fallback_reasons(monkeypatch)
    assert extract_centres(_stripe_with_faint_branch(100)).path == "fallback"
    assert reasons == ["a stripe component reaches the band's edge"]


@pytest.mark.parametrize("case", HARSH, ids=lambda c: c.name)
def test_band_path_gives_the_full_frame_result_on_the_field_harsh_cases(case) -> None:
    # Lit scenes fall back (their band would cover most of the frame); ghost and flare take
    # the wide band; the rest the band (BENCHMARKS.md, field-harsh cases).
    assert _assert_band_is_full(make_stripe(case).image) in {"band", "wide band", "fallback"}


@pytest.mark.parametrize("case", HARSH, ids=lambda c: c.name)
def test_band_path_gives_the_full_frame_result_with_the_gap_search(case) -> None:
    # The guided search reads only the frame and the kept chains (pipeline.extraction.gaps).
    image = make_stripe(case).image
    assert _assert_band_is_full(image, gap_search=True) in {"band", "wide band", "fallback"}


@pytest.mark.parametrize("name", REAL_FRAME_NAMES)
def test_band_path_gives_the_full_frame_result_on_the_real_frames(name: str) -> None:
    assert _assert_band_is_full(load_real_frame(name).image) in {"band", "wide band", "fallback"}


@pytest.mark.parametrize(
    ("mode", "seed"),
    [("clean", 3), pytest.param("harsh", 0, marks=pytest.mark.slow)],
)
def test_band_path_gives_the_full_frame_result_on_simulated_frames(mode: str, seed: int) -> None:
    # One axle (4 frames of 1600×1200 px): the clean pass's seed gives 3 band frames and a
    # wide band one; the harsh pass's lit frames all fall back (docs/extraction.md §7;
    # about 2 and 10 s on 2 cores).
    train_rng, pass_rng = np.random.default_rng(seed).spawn(2)
    train = build_train(1, train_rng, axles_per_vehicle=1)
    simulated = simulate_pass(
        train, build_station(), pass_rng, started_at=pass_start_time(0), field=FIELD_MODES[mode]
    )
    paths = [_assert_band_is_full(image) for image in simulated.frames.values()]
    assert ("wide band" if mode == "clean" else "fallback") in paths, paths
