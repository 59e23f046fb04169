"""Repeatability statistics (paper Tables 2–4) against hand-computed numbers."""

from __future__ import annotations

import math

import pytest

from benchmarks.field_repeatability import KEY_PARAMETERS
from benchmarks.repeatability import counts
from pipeline.archive.manifest import WheelEntry
from pipeline.profile.flange import FlangeParameters
from pipeline.profile.measurement import MEASURED, PassWheelResult, WheelMeasurement
from pipeline.profile.repeatability import (
    Observation,
    pass_observations,
    repeatability_markdown,
    summarise_repeatability,
)


def _obs(wheel: str, values, truth: float, method: str = "adaptive") -> list[Observation]:
    return [Observation(wheel, method, "flange_height_mm", v, truth) for v in values]


def test_per_wheel_statistics_by_hand() -> None:
    # Values 28.1, 27.9, 28.3 against 28.0: mean 28.1, MAE (0.1+0.1+0.3)/3, Std 0.2, ME 0.3.
    per_wheel, pooled = summarise_repeatability(_obs("w1", [28.1, 27.9, 28.3], 28.0))
    (s,) = per_wheel
    assert s.mean_mm == pytest.approx(28.1)
    assert s.mae_mm == pytest.approx(0.5 / 3)
    assert s.std_mm == pytest.approx(0.2)
    assert s.max_error_mm == pytest.approx(0.3)
    assert (s.passes, s.missing) == (3, 0)
    assert pooled[0].wheel == "all" and pooled[0].mae_mm == pytest.approx(0.5 / 3)


def test_pooled_std_is_the_largest_per_wheel_std() -> None:
    observations = _obs("w1", [1.0, 1.2], 1.0) + _obs("w2", [2.0, 2.0, 2.6], 2.0)
    per_wheel, pooled = summarise_repeatability(observations)
    stds = sorted(s.std_mm for s in per_wheel)
    assert pooled[0].std_mm == pytest.approx(stds[-1])
    assert pooled[0].max_error_mm == pytest.approx(0.6)
    assert pooled[0].mae_mm == pytest.approx((0.0 + 0.2 + 0.0 + 0.0 + 0.6) / 5)


def test_not_measured_values_are_counted_not_averaged() -> None:
    per_wheel, _ = summarise_repeatability(_obs("w1", [28.0, None, 28.2], 28.0))
    assert per_wheel[0].passes == 2 and per_wheel[0].missing == 1
    assert per_wheel[0].mean_mm == pytest.approx(28.1)


def test_single_pass_has_no_std() -> None:
    per_wheel, _ = summarise_repeatability(_obs("w1", [28.0], 28.0))
    assert math.isnan(per_wheel[0].std_mm)


def test_methods_are_reported_side_by_side() -> None:
    observations = _obs("w1", [1.0, 1.1], 1.0) + _obs("w1", [1.2, 1.4], 1.0, "steger")
    per_wheel, pooled = summarise_repeatability(observations)
    assert [s.method for s in pooled] == ["adaptive", "steger"]
    text = repeatability_markdown(per_wheel, pooled)
    assert "| flange_height_mm | all | steger | 1.000 | 1.300 | 0.300 |" in text


def test_a_wheel_without_sd_10_counts_only_sd_10_and_qr_as_not_measured() -> None:
    """Each value is observed on its own: a wheel whose flank at 10 mm was lost (Sd 10 and
    qR None) keeps its Sh and Sd in the statistics, and the benchmarks' counts of values
    not measured (all, and Sh/Sd in the field benchmark's per-wheel check) hold only the
    two missing ones."""
    parameters = FlangeParameters(28.1, 31.9, None, None, 0.0, "Sd 10: …; qR: …")
    measurement = WheelMeasurement(
        "right", "adaptive", MEASURED, None, parameters, None, (), 900, 800
    )
    wheel = WheelEntry("V002", 1, "right", ("inner.png",), ("outer.png",))
    truth = {"flange_height_mm": 28.0, "flange_thickness_mm": 32.0}
    truth |= {"flange_thickness_10_mm": 32.6, "qr_mm": 9.5}
    observations = pass_observations(
        [PassWheelResult(wheel, measurement, None)],
        [{"vehicle_id": "V002", "axle": 1, "side": "right", **truth}],
    )
    missing = {o.parameter for o in observations if o.value_mm is None}
    assert missing == {"flange_thickness_10_mm", "qr_mm"}
    assert counts(observations) == (1, 2)
    per_wheel, _ = summarise_repeatability(observations)
    key = {s.parameter: s for s in per_wheel if s.parameter in KEY_PARAMETERS}
    assert {p: (s.passes, s.missing) for p, s in key.items()} == dict.fromkeys(
        KEY_PARAMETERS, (1, 0)
    )
    assert key["flange_thickness_mm"].max_error_mm == pytest.approx(0.1)
