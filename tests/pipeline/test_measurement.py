"""Simulator → measurement end to end against the truth, and the measurement's bad inputs."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from pipeline.archive.pass_archive import read_pass_archive, write_pass_archive
from pipeline.profile.measurement import (
    MEASURED,
    NOT_MEASURED,
    axle_back_to_back,
    axle_conicity_of,
    measure_pass,
    measure_wheel,
)
from pipeline.profile.rails import track_rails
from pipeline.simulation.passes import write_synthetic_passes


@pytest.fixture(scope="module")
def sim_pass(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_synthetic_passes(tmp_path_factory.mktemp("e2e"), seed=11, axles_per_vehicle=1)[0]


@pytest.fixture(scope="module")
def results(sim_pass: Path):
    return measure_pass(read_pass_archive(sim_pass), methods=("adaptive", "steger"))


def _truth(sim_pass: Path) -> dict:
    rows = json.loads((sim_pass / "truth.json").read_text())["wheels"]
    return {(r["vehicle_id"], r["axle"], r["side"]): r for r in rows}


def test_adaptive_measurement_matches_truth(sim_pass: Path, results) -> None:
    truth = _truth(sim_pass)
    adaptive = [r for r in results if r.measurement.method == "adaptive"]
    assert len(adaptive) == 2
    for result in adaptive:
        m, w = result.measurement, result.wheel
        row = truth[(w.vehicle_id, w.axle, w.side)]
        assert m.status == MEASURED, m.reason
        assert m.parameters.flange_height_mm == pytest.approx(row["flange_height_mm"], abs=0.05)
        assert m.parameters.flange_thickness_mm == pytest.approx(
            row["flange_thickness_mm"], abs=0.05
        )
        assert m.parameters.flange_thickness_10_mm == pytest.approx(
            row["flange_thickness_10_mm"], abs=0.05
        )
        assert m.parameters.qr_mm == pytest.approx(row["qr_mm"], abs=0.15)
        assert result.back_to_back_mm == pytest.approx(row["back_to_back_mm"], abs=0.2)


def test_results_carry_quality_and_every_frames_centres(results) -> None:
    for result in results:
        m = result.measurement
        assert [f.sensor.split("_")[1] for f in m.frames] == ["inner", "outer"]
        assert m.points_inner > 500 and m.points_outer > 500
        assert m.profile is not None and 0 < m.profile.overlap_residual_mm < 0.15
        assert m.profile.x_mm.dtype == np.float64 and not m.profile.x_mm.flags.writeable
        frame = m.frames[0]
        assert frame.points_track_mm.shape == (len(frame.centres), 3)
        assert frame.centres.mask.shape == (1200, 1600)


def test_steger_is_measured_beside_adaptive(results) -> None:
    assert {r.measurement.method for r in results} == {"adaptive", "steger"}
    assert all(r.measurement.status == MEASURED for r in results)


def test_wheel_without_stripe_is_not_measured_and_the_other_is(sim_pass: Path) -> None:
    archive = read_pass_archive(sim_pass)
    left, right = archive.manifest.wheels
    dark = np.zeros((1200, 1600), np.uint8)
    blank = measure_wheel([dark], [dark], archive.calibration, side="left")
    assert blank.status == NOT_MEASURED
    assert "no usable stripe from the inner sensor" in blank.reason
    assert blank.parameters is None and blank.back_face_track_x_mm is None
    frames = [archive.load_frame(p) for p in right.frames_inner + right.frames_outer]
    good = measure_wheel(frames[:1], frames[1:], archive.calibration, side="right")
    assert good.status == MEASURED
    assert axle_back_to_back(blank, good) is None
    # The axle's reason names the wheel that is missing and why.
    conicity, reason = axle_conicity_of(blank, good, None, track_rails())
    assert conicity is None
    assert reason == f"the left wheel is not measured ({blank.reason})"


def test_frame_of_wrong_size_is_refused(sim_pass: Path) -> None:
    archive = read_pass_archive(sim_pass)
    small = np.zeros((100, 100), np.uint8)
    with pytest.raises(
        ValueError, match=r"left_inner frame 0 must be uint8 of shape \(1200, 1600\)"
    ):
        measure_wheel([small], [], archive.calibration, side="left")


def test_frame_of_wrong_dtype_is_refused(sim_pass: Path) -> None:
    archive = read_pass_archive(sim_pass)
    deep = np.zeros((1200, 1600), np.uint16)
    with pytest.raises(ValueError, match="must be uint8"):
        measure_wheel([], [deep], archive.calibration, side="right")


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"side": "middle"}, "side must be 'left' or 'right'"),
        ({"side": "left", "method": "magic"}, "method must be one of adaptive, steger"),
    ],
)
def test_bad_arguments(sim_pass: Path, kwargs, message: str) -> None:
    archive = read_pass_archive(sim_pass)
    with pytest.raises(ValueError, match=message):
        measure_wheel([], [], archive.calibration, **kwargs)


def test_pass_without_calibration_needs_the_site_one(sim_pass: Path, tmp_path: Path) -> None:
    archive = read_pass_archive(sim_pass)
    frames = {
        p: archive.frame_bytes(p)
        for w in archive.manifest.wheels
        for p in w.frames_inner + w.frames_outer
    }
    bare = write_pass_archive(tmp_path / "bare.zip", archive.manifest, frames)
    with pytest.raises(ValueError, match="no calibration.json"):
        measure_pass(read_pass_archive(bare))


@pytest.mark.slow
def test_every_wheel_of_a_clean_four_axle_pass_is_measured_by_the_adaptive_method(
    tmp_path_factory: pytest.TempPathFactory,
) -> None:
    """Every wheel measured by the adaptive method, and by Steger all but those whose flange
    top it loses: beside V001 axle 3 left's specular spots its fixed-σ chain turns off the
    stripe into a spot and leaves 3.5 mm of the crest without points, where the adaptive
    method's line test keeps the stripe (`line_test`)."""
    folder = tmp_path_factory.mktemp("clean4")
    (path,) = write_synthetic_passes(folder, seed=2026, axles_per_vehicle=4)
    results = measure_pass(read_pass_archive(path), methods=("adaptive", "steger"))
    truth = _truth(path)
    assert len(results) == 16
    lost = []
    for result in results:
        m, w = result.measurement, result.wheel
        if m.method == "steger" and m.status != MEASURED:
            assert "flange top" in m.reason, m.reason
            lost.append((w.vehicle_id, w.axle, w.side))
            continue
        assert m.status == MEASURED, f"{w.vehicle_id} {w.axle} {w.side} {m.method}: {m.reason}"
        row = truth[(w.vehicle_id, w.axle, w.side)]
        tolerance = 0.1 if m.method == "adaptive" else 0.6
        assert m.parameters.flange_height_mm == pytest.approx(
            row["flange_height_mm"], abs=tolerance
        )
    assert len(lost) <= 1, lost


def test_every_wheel_of_two_clean_one_axle_passes_of_seed_9_is_measured(
    tmp_path_factory: pytest.TempPathFactory,
) -> None:
    """Pass 2's left wheel: its dim flange tip beside specular spots is a line (the side a
    spot blocks is read against the background beyond it, `line_test`)."""
    folder = tmp_path_factory.mktemp("seed9")
    paths = write_synthetic_passes(folder, seed=9, axles_per_vehicle=1, repeat=2)
    for path in paths:
        for result in measure_pass(read_pass_archive(path), methods=("adaptive",)):
            m = result.measurement
            assert m.status == MEASURED, m.reason
            assert m.parameters is not None and m.parameters.qr_mm is not None, (
                m.parameters and m.parameters.reason
            )
