"""Field mode of the simulator: each effect does what it models, the truth never moves."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import cKDTree

from pipeline.archive.pass_archive import read_pass_archive
from pipeline.profile.measurement import MEASURED, measure_pass
from pipeline.profile.reference import load_reference_profile
from pipeline.simulation.field import (
    FIELD_MODES,
    FieldEffects,
    band_skew,
    bloom,
    cut_at_flange,
    glare,
    long_part,
    run_lengths_px,
    shiny_bands,
    stripe_texture,
)
from pipeline.simulation.frame_render import REACH_SIGMAS, draw_stripe
from pipeline.simulation.passes import (
    build_train,
    pass_start_time,
    simulate_pass,
    wear_train,
    write_synthetic_passes,
)
from pipeline.simulation.render import (
    StripeSamples,
    WheelPose,
    centred_view,
    plate_section,
    wheel_section,
)
from pipeline.simulation.station import build_station
from pipeline.simulation.wheel import wheel_profile

OFF = FieldEffects(**dict.fromkeys(FieldEffects.names(), False))


def _straight_samples(width_px: float, *, count: int = 200) -> StripeSamples:
    """A horizontal stripe along y = 100.25 from x = 20 to 180."""
    x = np.linspace(20.0, 180.0, count)
    return StripeSamples(
        pixels=np.column_stack([x, np.full(count, 100.25)]),
        width_px=np.full(count, width_px),
        irradiance=np.ones(count),
        outline_index=np.arange(count),
        run_id=np.ones(count, np.int64),
        points_track_mm=np.zeros((count, 3)),
    )


@pytest.fixture(scope="module")
def wheel_view():
    station = build_station()
    profile = wheel_profile(load_reference_profile("LMA"))
    pose, samples = centred_view(station, "right_outer", profile)
    return station, profile, pose, station.calibration.sensor("right_outer"), samples


def test_effects_switch_off_one_by_one_and_reject_unknown_names() -> None:
    harsh = FIELD_MODES["harsh"]
    assert all(dataclasses.asdict(harsh).values()) and FIELD_MODES["clean"] is None
    assert not harsh.without("ghost").ghost and harsh.without("ghost").scene
    with pytest.raises(ValueError, match="unknown field effect 'fog'"):
        harsh.without("fog")


def test_two_sided_stripe_keeps_its_peak_on_the_true_line() -> None:
    image = np.zeros((200, 200), np.float32)
    samples = _straight_samples(40.0)
    draw_stripe(image, samples, np.full(200, 100.0), skew=np.full(200, 0.25))
    column = image[:, 100].astype(float)
    rows = np.arange(200.0)
    assert abs(rows[np.argmax(column)] - 100.25) <= 0.5
    # σ(1 ± α): the half-maximum reach on the two sides differs by 1.25 / 0.75.
    above = rows[column >= 0.5 * column.max()]
    left, right = 100.25 - above.min(), above.max() - 100.25
    assert max(left, right) / min(left, right) == pytest.approx(1.25 / 0.75, rel=0.1)


def _band_skews(radius_mm: float) -> dict[str, np.ndarray]:
    station = build_station()
    profile = wheel_profile(load_reference_profile("LMA"))
    skews = {}
    for side, side_sign in (("left", -1), ("right", 1)):
        pose = WheelPose((0.0, 0.0, radius_mm), (1.0, 0.0, 0.0), side_sign, 1353.0 / 2, radius_mm)
        for position in ("inner", "outer"):
            name = f"{side}_{position}"
            sensor = station.calibration.sensor(name)
            samples = wheel_section(
                profile,
                pose,
                sensor,
                station.laser_origin(name),
                scatter_mm=np.full(profile.x_mm.size, 0.5),
            )
            assert samples.pixels.shape[0] > 500, name
            skews[name] = band_skew(profile, samples, pose, sensor)
    return skews


def test_the_lit_band_turns_with_the_wheels_circumference_not_its_profile() -> None:
    """The band runs across the laser plane, so its own asymmetry comes from the rim's
    curvature round the axle (1/r): small on a 410 mm wheel, about 3× larger on an 80 mm
    one, and mirrored between the rails (the left cameras are the right's mirrored)."""
    wheel, small = _band_skews(410.0), _band_skews(80.0)
    for name, alpha in wheel.items():
        assert np.percentile(np.abs(alpha), 99) < 0.02, name
        assert np.median(np.abs(small[name])) > 2.0 * np.median(np.abs(alpha)), name
    for position in ("inner", "outer"):
        left, right = (np.median(wheel[f"{side}_{position}"]) for side in ("left", "right"))
        assert left == pytest.approx(-right, rel=0.2) and left != 0.0


def test_stripe_texture_has_the_contrast_it_is_drawn_with() -> None:
    texture = stripe_texture((400, 400), np.random.default_rng(3))
    contrast = texture.std() / texture.mean()
    assert texture.mean() == pytest.approx(1.0, abs=0.05)
    assert 0.15 <= contrast <= 0.65


def test_other_part_stripe_is_longer_than_a_piece_of_the_wheels(wheel_view) -> None:
    station, profile, pose, sensor, samples = wheel_view
    samples = cut_at_flange(profile, samples, np.random.default_rng(2))
    plate = plate_section(
        sensor,
        station.laser_origin("right_outer"),
        plate_x_mm=pose.back_face_axial_mm + 170.0,
        z_range_mm=(-30.0, 250.0),
        scatter_mm=0.5,
    )
    pieces = run_lengths_px(samples)
    part = run_lengths_px(long_part(plate, samples, np.random.default_rng(1))).max()
    assert 1.14 <= part / pieces[pieces >= 50].min() <= 1.61


def test_flange_cut_removes_a_stretch_of_the_flank_and_splits_the_run(wheel_view) -> None:
    _, profile, _, _, samples = wheel_view
    cut = cut_at_flange(profile, samples, np.random.default_rng(2))
    assert 0 < samples.pixels.shape[0] - cut.pixels.shape[0] < 0.2 * samples.pixels.shape[0]
    assert np.unique(cut.run_id).size == np.unique(samples.run_id).size + 1


def test_glare_lies_on_the_lit_line_between_its_stretches(wheel_view) -> None:
    """The polished bands' glare comes in stretches along the line; drawn, it lies on the
    true line only (before pipeline 0.11.8 consecutive stretches were joined by straight
    chords, up to 14 px off the curved line on the outer sensor's flank)."""
    _, profile, _, _, samples = wheel_view
    for seed in range(4):
        rng = np.random.default_rng(seed)
        _, band = shiny_bands(profile, samples, rng)
        shiny, peak = glare(samples, band, rng)
        assert np.unique(shiny.run_id).size >= 3, seed  # several stretches
        image = np.zeros((1200, 1600), np.float32)
        draw_stripe(image, shiny, peak)
        rows, cols = np.nonzero(image > 0.0)
        lit = np.column_stack([cols, rows]).astype(float)
        # distance of each lit pixel from the true line (the samples are 0.34 px apart)
        nearest, _ = cKDTree(samples.pixels).query(lit)
        reach = REACH_SIGMAS * shiny.width_px.max() / 4.0 + 1.5
        assert nearest.max() <= reach, (seed, nearest.max(), reach)


def test_blooming_spreads_only_charge_above_full_well() -> None:
    image = np.full((60, 60), 40.0, np.float32)
    image[30, 30] = 2000.0
    before = image.copy()
    bloom(image)
    added = image - before
    assert added[30, 36] > 0.0 and added[36, 30] > 0.0
    # A halo only: the CMOS pixels move no charge along their column, so the spill below a
    # glint is what it is beside it, and nothing lies beyond the halo (a column streak
    # drew a dim line under each glare stretch: docs/simulator.md).
    np.testing.assert_allclose(added[31:, 30], added[30, 31:], atol=1e-4)
    assert added[30 + 12 :, 30].max() == 0.0 and added[: 30 - 12, 30].max() == 0.0
    dim = np.full((60, 60), 200.0, np.float32)
    bloom(dim)
    assert np.array_equal(dim, np.full((60, 60), 200.0, np.float32))


@pytest.fixture(scope="module")
def scene_pass(tmp_path_factory: pytest.TempPathFactory) -> Path:
    field = dataclasses.replace(OFF, scene=True)
    out = tmp_path_factory.mktemp("field")
    return write_synthetic_passes(out, seed=7, axles_per_vehicle=1, field=field)[0]


def test_lit_scene_reads_grey_15_to_90_and_records_the_effects(scene_pass: Path) -> None:
    truth = json.loads((scene_pass / "truth.json").read_text())
    assert truth["field"] == dataclasses.asdict(dataclasses.replace(OFF, scene=True))
    archive = read_pass_archive(scene_pass)
    frame = archive.load_frame(archive.manifest.wheels[0].frames_inner[0])
    assert 15 <= np.median(frame) <= 90


@pytest.mark.slow
def test_lit_scene_does_not_break_measurement(scene_pass: Path) -> None:
    results = measure_pass(read_pass_archive(scene_pass), methods=("adaptive", "steger"))
    assert [r.measurement.status for r in results] == [MEASURED] * 4
    quality = results[0].measurement.quality_figures()
    assert 0 < quality["searched_fraction"] < 1 and quality["excluded_bright_px"] > 0


def test_a_worn_train_keeps_its_wheels_with_flanges_thinner_by_the_wear() -> None:
    train = build_train(2, np.random.default_rng(3), axles_per_vehicle=1)
    worn = wear_train(train, 0.5)
    for before, after in zip(train.wheels, worn.wheels, strict=True):
        assert (after.vehicle_id, after.axle, after.side) == (
            before.vehicle_id,
            before.axle,
            before.side,
        )
        assert after.back_to_back_mm == before.back_to_back_mm
        assert after.wear.flange_thinning_mm == pytest.approx(before.wear.flange_thinning_mm + 0.5)
        thinner = before.profile.truth.flange_thickness_mm - after.profile.truth.flange_thickness_mm
        assert thinner == pytest.approx(0.5, abs=0.02), "the flank moves by the wear at 12 mm"
        assert after.appearance.reflectivity.shape == after.profile.x_mm.shape
    with pytest.raises(ValueError, match="flange_thinning_mm must be ≥ 0"):
        wear_train(train, -0.1)


def test_switching_an_effect_off_changes_only_its_own_pixels_in_every_frame() -> None:
    """Paired renderings: each frame draws from its own children of the pass's generator and
    the noise does not depend on the grey, so the flange ghost (outer frames only) changes
    no inner frame, nor any pixel of a later axle's outer frame away from the ghost."""
    station = build_station()
    train = build_train(1, np.random.default_rng(5), axles_per_vehicle=2)

    def frames(field: FieldEffects) -> dict[str, np.ndarray]:
        rng = np.random.default_rng(11)
        return simulate_pass(train, station, rng, started_at=pass_start_time(0), field=field).frames

    with_ghost, without = (
        frames(FIELD_MODES["harsh"]),
        frames(FIELD_MODES["harsh"].without("ghost")),
    )
    assert with_ghost.keys() == without.keys()
    for path, image in with_ghost.items():
        changed = np.mean(image != without[path])
        if "inner" in path:
            assert changed == 0, path
        else:
            assert 0 < changed < 0.005, (path, changed)
