"""Calibration file `wheelscan-calibration/1`: round trip and one clear error per fault."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from pipeline.calibration.model import (
    calibration_to_document,
    load_calibration_json,
    read_calibration,
    write_calibration,
)
from pipeline.errors import CalibrationError
from tests.pipeline.archive_helpers import small_calibration


def test_write_then_read_round_trips_exactly(tmp_path: Path) -> None:
    calibration = small_calibration()
    write_calibration(calibration, tmp_path / "c.json")
    again = read_calibration(tmp_path / "c.json")
    assert again.sensor_names == ("left_inner", "left_outer", "right_inner", "right_outer")
    for a, b in zip(calibration.sensors, again.sensors, strict=True):
        np.testing.assert_array_equal(a.camera_matrix, b.camera_matrix)
        np.testing.assert_array_equal(a.dist_coeffs, b.dist_coeffs)
        np.testing.assert_array_equal(a.laser_plane.normal, b.laser_plane.normal)
        assert a.laser_plane.d_mm == b.laser_plane.d_mm
        np.testing.assert_array_equal(a.T_track_camera, b.T_track_camera)
        assert (b.image_width_px, b.image_height_px, b.bit_depth) == (40, 30, 8)
        assert b.frame_dtype == np.uint8


def test_arrays_are_read_only() -> None:
    sensor = small_calibration().sensors[0]
    with pytest.raises(ValueError, match="read-only"):
        sensor.camera_matrix[0, 0] = 1.0


def _document() -> dict:
    return calibration_to_document(small_calibration())


def _sensor(document: dict) -> dict:
    return document["sensors"]["left_inner"]


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda d: d.update(format="x/1"), "format must be 'wheelscan-calibration/1'"),
        (lambda d: d.update(sensors={}), "non-empty object"),
        (lambda d: d["sensors"].update(centre=_sensor(d)), "unknown sensor 'centre'"),
        (lambda d: _sensor(d).pop("laser_plane"), "lacks 'laser_plane'"),
        (lambda d: _sensor(d).pop("camera_to_track"), "lacks 'camera_to_track'"),
        (lambda d: _sensor(d).update(camera_matrix=[[1, 0], [0, 1]]), r"shape \(3, 3\)"),
        (
            lambda d: _sensor(d).update(camera_matrix=[[-5, 0, 1], [0, 5, 1], [0, 0, 1]]),
            "focal lengths must be > 0",
        ),
        (lambda d: _sensor(d).update(dist_coeffs=[0, 0, 0, 0]), r"shape \(5,\)"),
        (lambda d: _sensor(d).update(dist_coeffs=[0, "a", 0, 0, 0]), "must be numbers"),
        (
            lambda d: _sensor(d)["laser_plane"].update(normal=[0, 0, 2]),
            "normal must be a unit vector",
        ),
        (lambda d: _sensor(d)["laser_plane"].update(d=float("nan")), "d must be a finite"),
        (lambda d: _sensor(d)["laser_plane"].update(d=0.0), "through the camera centre"),
        (lambda d: _sensor(d)["laser_plane"].update(d=-0.5), "at least 1.0 mm from 0"),
        (lambda d: _sensor(d).update(image_size=[60000, 60000]), "exceeds 33554432 pixels"),
        (lambda d: _sensor(d).update(camera_to_track=np.diag([1, 1, -1, 1]).tolist()), "det"),
        (
            lambda d: _sensor(d).update(camera_to_track=(2 * np.eye(4)).tolist()),
            "last row|orthonormal",
        ),
        (lambda d: _sensor(d).update(bit_depth=12), "bit_depth must be 8 or 16"),
        (lambda d: _sensor(d).update(image_size=[40]), r"image_size must be \[width, height\]"),
        (lambda d: _sensor(d)["residuals"].update(plane_rms_mm=-1), "must be ≥ 0"),
    ],
)
def test_faults_get_one_clear_message(edit, message: str) -> None:
    document = _document()
    edit(document)
    with pytest.raises(CalibrationError, match=message):
        load_calibration_json(json.dumps(document))


def test_malformed_json() -> None:
    with pytest.raises(CalibrationError, match="not valid JSON"):
        load_calibration_json("{")


def test_missing_file_names_the_path(tmp_path: Path) -> None:
    with pytest.raises(CalibrationError, match="cannot read calibration .*none.json"):
        read_calibration(tmp_path / "none.json")


def test_unknown_sensor_lookup() -> None:
    with pytest.raises(CalibrationError, match="no sensor 'left_middle'"):
        small_calibration().sensor("left_middle")
