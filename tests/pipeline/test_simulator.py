"""Pass simulator: valid archives, exact truth, reproducible from the seed, physical looks."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from pipeline.archive.pass_archive import read_pass_archive
from pipeline.profile.reference import load_reference_profile
from pipeline.simulation.passes import write_synthetic_passes
from pipeline.simulation.render import WheelPose, wheel_section
from pipeline.simulation.station import IMAGE_HEIGHT_PX, IMAGE_WIDTH_PX, build_station
from pipeline.simulation.wheel import Wear, wheel_profile


@pytest.fixture(scope="module")
def passes(tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    out = tmp_path_factory.mktemp("synth")
    return write_synthetic_passes(out, vehicles=1, seed=3, repeat=2, axles_per_vehicle=1)


def test_written_passes_are_valid_archives_with_true_calibration(passes: list[Path]) -> None:
    assert [p.name for p in passes] == ["pass-001", "pass-002"]
    archive = read_pass_archive(passes[0])
    assert archive.has_own_calibration
    assert [(w.axle, w.side) for w in archive.manifest.wheels] == [(1, "left"), (1, "right")]
    frame = archive.load_frame(archive.manifest.wheels[0].frames_inner[0])
    assert frame.shape == (IMAGE_HEIGHT_PX, IMAGE_WIDTH_PX) and frame.dtype == np.uint8


def test_repeats_share_truth_but_not_pixels(passes: list[Path]) -> None:
    truths = [json.loads((p / "truth.json").read_text()) for p in passes]
    assert truths[0] == truths[1]
    row = truths[0]["wheels"][0]
    assert set(row) >= {
        "vehicle_id",
        "axle",
        "side",
        "flange_height_mm",
        "flange_thickness_mm",
        "flange_thickness_10_mm",
        "qr_mm",
        "back_to_back_mm",
    }
    a = (passes[0] / "frames/left_inner/000001.png").read_bytes()
    b = (passes[1] / "frames/left_inner/000001.png").read_bytes()
    assert a != b


def test_same_seed_gives_identical_files(tmp_path: Path) -> None:
    one = write_synthetic_passes(tmp_path / "a", seed=5, axles_per_vehicle=1)[0]
    two = write_synthetic_passes(tmp_path / "b", seed=5, axles_per_vehicle=1)[0]
    for path in sorted(one.rglob("*.png")):
        assert path.read_bytes() == (two / path.relative_to(one)).read_bytes()


def test_sixteen_bit_passes(tmp_path: Path) -> None:
    folder = write_synthetic_passes(tmp_path, seed=1, axles_per_vehicle=1, bit_depth=16)[0]
    archive = read_pass_archive(folder)
    frame = archive.load_frame(archive.manifest.wheels[1].frames_outer[0])
    assert frame.dtype == np.uint16 and frame.max() > 255


def test_unworn_wheel_truth_is_the_reference_table() -> None:
    truth = wheel_profile(load_reference_profile("LMA")).truth
    assert truth.flange_height_mm == pytest.approx(28.0, abs=0.001)
    assert truth.flange_thickness_mm == pytest.approx(31.9744, abs=0.001)
    assert truth.qr_mm == pytest.approx(9.7399, abs=0.001)


def test_wear_moves_the_parameters_the_way_wear_does() -> None:
    reference = load_reference_profile("LMA")
    new = wheel_profile(reference).truth
    thinned = wheel_profile(reference, Wear(flange_thinning_mm=2.0)).truth
    hollow = wheel_profile(reference, Wear(hollow_depth_mm=0.8)).truth
    assert thinned.flange_thickness_mm == pytest.approx(new.flange_thickness_mm - 2.0, abs=0.05)
    assert thinned.flange_height_mm == pytest.approx(new.flange_height_mm, abs=1e-6)
    assert hollow.flange_height_mm > new.flange_height_mm + 0.5


def _section(name: str):
    station = build_station()
    profile = wheel_profile(load_reference_profile("LMA"))
    side = 1 if name.startswith("right") else -1
    pose = WheelPose((0.0, 0.0, 410.0), (1.0, 0.0, 0.0), side, 676.5, 410.0)
    samples = wheel_section(
        profile,
        pose,
        station.calibration.sensor(name),
        station.laser_origin(name),
        scatter_mm=np.full(profile.x_mm.size, 0.6),
    )
    return profile, samples


@pytest.mark.parametrize("name", ["left_inner", "right_inner"])
def test_inner_sensor_sees_back_face_and_flange_top(name: str) -> None:
    profile, samples = _section(name)
    x = profile.x_mm[samples.outline_index]
    assert x.min() == 0.0
    assert np.any(np.abs(x - 16.0) < 0.5)


@pytest.mark.parametrize("name", ["left_outer", "right_outer"])
def test_outer_sensor_sees_flank_tread_and_chamfer_but_not_back_face(name: str) -> None:
    profile, samples = _section(name)
    x = profile.x_mm[samples.outline_index]
    assert x.min() > 5.0
    for needed in (16.0, 32.0, 70.0, 132.0):
        assert np.any(np.abs(x - needed) < 0.5), needed


def test_stripe_widths_span_the_papers_range() -> None:
    widths = np.concatenate([_section(n)[1].width_px for n in ("right_inner", "right_outer")])
    assert 4.0 <= widths.min() <= 7.0
    assert 15.0 <= widths.max() <= 22.0
