"""Centre and normal accuracy on straight Gaussian stripes at sub-pixel offsets and angles."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline import extract_centres


def straight_stripe(
    angle_deg: float, offset_px: float, width_px: float, *, dtype=np.uint8, shape=(120, 160)
) -> np.ndarray:
    """A Gaussian stripe (1/e² full width `width_px`) through the frame centre + offset."""
    rows, cols = np.mgrid[0 : shape[0], 0 : shape[1]].astype(float)
    theta = np.deg2rad(angle_deg)
    normal = np.array([-np.sin(theta), np.cos(theta)])  # (x, y)
    centre = np.array([shape[1] / 2, shape[0] / 2]) + offset_px * normal
    distance = (cols - centre[0]) * normal[0] + (rows - centre[1]) * normal[1]
    grey = 12 + 170 * np.exp(-8 * distance**2 / width_px**2)
    scale = 257 if dtype == np.uint16 else 1
    return np.rint(grey * scale).astype(dtype)


def line_errors(centres, angle_deg: float, offset_px: float, shape=(120, 160)):
    """Distances [px] of centres to the true line and normal angle errors [deg]."""
    theta = np.deg2rad(angle_deg)
    normal = np.array([-np.sin(theta), np.cos(theta)])
    centre = np.array([shape[1] / 2, shape[0] / 2]) + offset_px * normal
    margin = 35  # the reflected border reaches 4σ2 = 30 px in
    inside = (
        (centres.x > margin)
        & (centres.x < shape[1] - 1 - margin)
        & (centres.y > margin)
        & (centres.y < shape[0] - 1 - margin)
    )
    distance = (centres.x - centre[0]) * normal[0] + (centres.y - centre[1]) * normal[1]
    cosine = np.abs(centres.nx * normal[0] + centres.ny * normal[1])
    angle = np.degrees(np.arccos(np.clip(cosine, 0, 1)))
    return distance[inside], angle[inside]


@pytest.mark.parametrize("method", ["adaptive", "steger", "classic"])
@pytest.mark.parametrize(
    ("angle_deg", "offset_px", "width_px"),
    [(0, 0.3, 5), (17, -0.41, 9), (45, 0.25, 13), (73, 0.11, 21), (90, -0.37, 7), (132, 0.45, 15)],
)
def test_straight_stripe_centre_and_normal(method, angle_deg, offset_px, width_px) -> None:
    image = straight_stripe(angle_deg, offset_px, width_px)
    centres = extract_centres(image, method)
    distance, angle = line_errors(centres, angle_deg, offset_px)
    assert distance.size > 40
    assert np.abs(distance).max() < 0.05
    assert angle.max() < 0.5


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
def test_frame_types_give_the_same_centres(dtype) -> None:
    image = straight_stripe(30, 0.2, 9, dtype=dtype)
    centres = extract_centres(image)
    distance, _ = line_errors(centres, 30, 0.2)
    assert np.abs(distance).max() < 0.05


def test_result_arrays_are_read_only_and_typed() -> None:
    centres = extract_centres(straight_stripe(10, 0.0, 9))
    arrays = [centres.x, centres.y, centres.nx, centres.ny, centres.sigma, centres.strength]
    arrays.append(centres.width_px)
    assert {a.dtype for a in arrays} == {np.dtype(np.float64)}
    assert len({a.shape for a in arrays}) == 1
    assert centres.mask.dtype == bool and centres.mask.shape == (120, 160)
    assert centres.sigma_map is not None and centres.sigma_map.dtype == np.float32
    for array in [*arrays, centres.mask, centres.sigma_map]:
        with pytest.raises(ValueError, match="read-only"):
            array[0] = 0
    np.testing.assert_allclose(np.hypot(centres.nx, centres.ny), 1, atol=1e-6)
    covered = np.concatenate(centres.polylines)
    np.testing.assert_array_equal(covered, np.arange(len(centres)))


def test_sigma_map_is_chosen_scale_inside_mask_and_zero_outside() -> None:
    centres = extract_centres(straight_stripe(0, 0.0, 5))
    assert centres.sigma_map is not None
    assert np.all(centres.sigma_map[~centres.mask] == 0)
    inside = centres.sigma_map[centres.mask]
    assert set(np.unique(inside)) <= {0.0, *np.float32(centres.sigmas_px)}
    assert np.all(np.isin(np.float32(centres.sigma), np.float32(centres.sigmas_px)))


@pytest.mark.parametrize(("width_px", "sigma_index"), [(5, 0), (21, 1)])
def test_adaptive_picks_the_scale_matching_the_width(width_px, sigma_index) -> None:
    centres = extract_centres(straight_stripe(20, 0.0, width_px))
    chosen = np.unique(centres.sigma)
    assert chosen.tolist() == [pytest.approx(centres.sigmas_px[sigma_index])]


@pytest.mark.parametrize("width_px", [5, 11, 19])
def test_width_per_point_matches_the_stripe(width_px) -> None:
    centres = extract_centres(straight_stripe(25, 0.0, width_px))
    assert np.nanmedian(centres.width_px) == pytest.approx(width_px, rel=0.1)


def test_fixed_sigma_is_used_by_steger() -> None:
    centres = extract_centres(straight_stripe(0, 0.0, 9), "steger", sigma=4.0)
    assert centres.sigmas_px == (4.0,)
    assert np.all(centres.sigma == 4.0)
    assert centres.sigma_map is None
