"""A harsh field pass measured end to end: each wheel is measured near its truth or says
which part of its profile is missing; a measured wheel reports the flank gap it bridged."""

from __future__ import annotations

import math
import re
from pathlib import Path

import pytest

from pipeline.archive.pass_archive import read_pass_archive
from pipeline.profile.flange import MAX_FLANK_GAP_MM
from pipeline.profile.measurement import MEASURED, measure_pass
from pipeline.simulation.field import FIELD_MODES
from pipeline.simulation.passes import read_truth, write_synthetic_passes

FIELD_ERROR_MM = 0.25
"""Sh and Sd of the adaptive method within 0.25 mm of the truth on a harsh pass (the measured
wheels' largest errors on 3 harsh passes of 8 wheels: Sh 0.23, Sd 0.15 mm). Fixed-σ Steger,
the comparison, is not held to it: on harsh frames it measures wheels over 1 mm off (this
pass's V002/1/right: Sh −1.29 mm; BENCHMARKS.md, field section)."""
MISSING_PART = re.compile(r"flank near z = [\d.]+ mm \(a gap of|flange top")


@pytest.fixture(scope="module")
def harsh_pass(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("harsh")
    return write_synthetic_passes(
        out, vehicles=2, seed=2027, axles_per_vehicle=1, field=FIELD_MODES["harsh"]
    )[0]


@pytest.fixture(scope="module")
def measured(harsh_pass: Path) -> tuple[tuple, dict]:
    truth = {(t["vehicle_id"], t["axle"], t["side"]): t for t in read_truth(harsh_pass)}
    return measure_pass(read_pass_archive(harsh_pass), methods=("adaptive", "steger")), truth


@pytest.mark.slow
def test_each_wheel_is_measured_or_says_what_is_missing(measured) -> None:
    results, _ = measured
    for result in results:
        m = result.measurement
        if m.status != MEASURED:
            assert m.parameters is None and MISSING_PART.search(m.reason), m.reason
            continue
        gap = m.quality_figures()["flank_gap_mm"]
        assert math.isfinite(gap) and 0.0 <= gap <= MAX_FLANK_GAP_MM
    assert any(r.measurement.status == MEASURED for r in results)


@pytest.mark.slow
def test_each_measured_wheel_is_near_its_truth(measured) -> None:
    results, truth = measured
    for result in results:
        m, wheel = result.measurement, result.wheel
        if m.status != MEASURED or m.method != "adaptive":
            continue
        t = truth[(wheel.vehicle_id, wheel.axle, wheel.side)]
        assert m.parameters.flange_height_mm == pytest.approx(
            t["flange_height_mm"], abs=FIELD_ERROR_MM
        )
        sd = m.parameters.flange_thickness_mm
        if sd is None:  # a flank gap at 12 mm: the wheel keeps Sh, the reason names Sd
            assert m.parameters.reason is not None and m.parameters.reason.startswith("Sd: ")
        else:
            assert sd == pytest.approx(t["flange_thickness_mm"], abs=FIELD_ERROR_MM)
