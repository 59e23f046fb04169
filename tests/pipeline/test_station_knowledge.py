"""What the station knows: the search region, the wheel window, method labels."""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

from pipeline.calibration.search_region import stripe_search_region
from pipeline.extraction.centres import extract_centres
from pipeline.imaging import PixelRegion
from pipeline.profile.measurement import method_options
from pipeline.profile.reference import load_reference_profile
from pipeline.profile.window import in_wheel_window, locate_back_face
from pipeline.simulation.render import WheelPose, wheel_section
from pipeline.simulation.station import build_station
from pipeline.simulation.wheel import Wear, wheel_profile
from tests.pipeline.archive_helpers import small_calibration


def _sections(side: str, position: str):
    """True stripe samples of worn LMA and S1002 wheels at the extremes of lateral shift."""
    station = build_station()
    sensor = station.calibration.sensor(f"{side}_{position}")
    sign = 1 if side == "right" else -1
    for name, half in (("LMA", 1350.0 / 2), ("S1002", 1363.0 / 2)):
        profile = wheel_profile(load_reference_profile(name), Wear(1.5, 2.5, 1.0))
        for offset in (-8.0, 8.0):
            pose = WheelPose((offset, 2.0, 405.0), (1.0, 0.0, 0.0), sign, half, 405.0)
            yield (
                sensor,
                wheel_section(
                    profile,
                    pose,
                    sensor,
                    station.laser_origin(f"{side}_{position}"),
                    scatter_mm=np.full(profile.x_mm.size, 0.5),
                ),
            )


@pytest.mark.parametrize("name", ["left_inner", "right_outer"])
def test_search_region_holds_every_possible_wheel_stripe(name: str) -> None:
    side, position = name.split("_")
    for sensor, samples in _sections(side, position):
        region = stripe_search_region(sensor, side)
        assert region is not None
        x, y = samples.pixels.T
        assert region.area_px < 0.8 * sensor.image_width_px * sensor.image_height_px
        assert np.all((x >= region.col_start) & (x < region.col_stop))
        assert np.all((y >= region.row_start) & (y < region.row_stop))


def test_a_camera_that_does_not_see_the_window_searches_its_whole_frame() -> None:
    """A 40×30 px frame of a real sensor's calibration sees none of the wheel window."""
    sensor = build_station().calibration.sensor("left_inner")
    tiny = dataclasses.replace(sensor, image_width_px=40, image_height_px=30)
    assert stripe_search_region(tiny, "left") is None


def test_window_points_at_or_behind_the_camera_do_not_reach_the_bounds() -> None:
    """A camera at the track origin has half the window behind it and grid points on its
    plane, which the distortion polynomial sends beyond 1e19 px: they are left out, and the
    box is cast without an overflow."""
    sensor = small_calibration().sensor("left_inner")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        region = stripe_search_region(sensor, "left")
    assert region is None or (
        0 <= region.row_start < region.row_stop <= sensor.image_height_px
        and 0 <= region.col_start < region.col_stop <= sensor.image_width_px
    )
    away = np.diag([1.0, -1.0, -1.0, 1.0])  # at Z = −100 mm, looking down, away from it
    away[2, 3] = -100.0
    behind = dataclasses.replace(sensor, T_track_camera=away)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert stripe_search_region(behind, "left") is None


def test_wheel_window_keeps_the_wheel_and_drops_what_is_off_it() -> None:
    for _, samples in _sections("right", "outer"):
        points = samples.points_track_mm
        assert in_wheel_window(points, "right").all()
        back_face = locate_back_face(points, "right")
        assert back_face is not None
        assert in_wheel_window(points, "right", back_face_mm=back_face).mean() > 0.99
        tread = (np.abs(points[:, 2]) < 2) & (points[:, 0] - back_face > 70)
        lifted = points[tread] + [0.0, 0.0, -25.0]  # 25 mm above the tread: not on a wheel
        assert tread.sum() > 50 and not in_wheel_window(lifted, "right").any()
    with pytest.raises(ValueError, match="side must be"):
        in_wheel_window(np.zeros((1, 3)), "middle")


def test_region_crop_gives_the_same_centres_in_frame_coordinates() -> None:
    rows, cols = np.mgrid[0:160, 0:240].astype(float)
    line = 80.3 + 0.2 * (cols - 120)
    image = (12 + 140 * np.exp(-2 * ((rows - line) / 8) ** 2)).astype(np.uint8)
    whole = extract_centres(image)
    region = PixelRegion(20, 150, 30, 230)
    cropped = extract_centres(image, region=region)
    assert cropped.region == region and whole.region is None
    assert not cropped.mask[:20].any() and not cropped.mask[:, :30].any()
    inner = (whole.x > 50) & (whole.x < 210)
    ours = (cropped.x > 50) & (cropped.x < 210)
    assert np.median(cropped.y[ours] - (80.3 + 0.2 * (cropped.x[ours] - 120))) == pytest.approx(
        np.median(whole.y[inner] - (80.3 + 0.2 * (whole.x[inner] - 120))), abs=0.01
    )
    with pytest.raises(ValueError, match="region must be a non-empty part of a 160×240"):
        extract_centres(image, region=PixelRegion(20, 10, 0, 50))


def test_method_labels_switch_corrections_and_name_bad_ones() -> None:
    options = method_options("steger+curvature+asymmetry")
    assert (options.method, options.curvature_correction, options.asymmetry_correction) == (
        "steger",
        True,
        True,
    )
    assert not method_options("adaptive-curvature").curvature_correction
    assert method_options("adaptive+scatter").scatter_support
    assert method_options("adaptive").normal_fit
    assert not method_options("adaptive-normal").normal_fit
    assert not method_options("steger").normal_fit
    with pytest.raises(ValueError, match="corrections are"):
        method_options("adaptive+sharpen")
    with pytest.raises(ValueError, match="method must be one of"):
        method_options("canny")
