"""Handheld-gauge files in, profile files out: orientation, re-referencing, parameters of
sparse flanks, round trips, and the errors a user can fix.

The gauge files are written here from the published reference tables (whose parameters
are known to 0.0003 mm), in the ways real files differ: back→field or field→back, x from
the back face or from the tape circle, z up or down, a few tenths of a mm off in z, and
sampled every 0.2–1 mm along the contour as handheld gauges do.
"""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.profile.exchange import (
    ProfileFileError,
    handheld_parameters,
    parse_profile_file,
    profile_csv_text,
    profile_whl_text,
    read_profile_text,
)
from pipeline.profile.flange import FlangeNotFoundError, curve_flange_parameters
from pipeline.profile.reference import load_reference_profile
from pipeline.profile.repeatability import Observation, summarise_agreement

KEYS = ("flange_height_mm", "flange_thickness_mm", "flange_thickness_10_mm", "qr_mm")


def contour_samples(name: str, step_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """The reference profile resampled every `step_mm` of arc length (as a gauge samples)."""
    table = load_reference_profile(name)
    arc = np.concatenate([[0], np.cumsum(np.hypot(np.diff(table.x_mm), np.diff(table.z_mm)))])
    t = np.arange(0.0, arc[-1], step_mm)
    return np.interp(t, arc, table.x_mm), np.interp(t, arc, table.z_mm)


def gauge_file(
    x: np.ndarray,
    z: np.ndarray,
    *,
    reverse: bool = False,
    tape_circle: bool = False,
    x_origin_mm: float = 0.0,
    mirror: bool = False,
    z_down: bool = False,
    z_offset_mm: float = 0.0,
    header: str = "",
) -> str:
    xs = (x - 70.0 if tape_circle else x) - x_origin_mm
    xs = x_origin_mm - x if mirror else xs
    zs = z + z_offset_mm
    zs = -zs if z_down else zs
    if reverse:
        xs, zs = xs[::-1], zs[::-1]
    rows = "\n".join(f"{a:.3f} {b:.3f}" for a, b in zip(xs, zs, strict=True))
    return f"{header}ColumnDef=X,Y\nXYPoints={x.size}\n\n{rows}\n"


@pytest.mark.parametrize("name", ["LMA", "S1002"])
@pytest.mark.parametrize(
    "layout",
    [
        {},
        {"reverse": True},
        {"tape_circle": True, "z_down": True},
        {"reverse": True, "tape_circle": True, "z_offset_mm": -0.37},
        {"z_offset_mm": 0.42, "z_down": True, "reverse": True},
        {"x_origin_mm": 16.0},
        {"mirror": True, "x_origin_mm": 135.0},
        {"mirror": True, "z_down": True},
    ],
)
def test_a_gauge_file_in_any_layout_gives_the_profiles_parameters(name, layout) -> None:
    truth = curve_flange_parameters(*contour_samples(name, 0.01))
    x, z = contour_samples(name, 0.5)
    profile = read_profile_text(gauge_file(x, z, **layout), suffix=".whl")
    assert profile.x_mm[0] < profile.x_mm[-1] and profile.z_mm.max() > 27
    assert np.interp(70.0, profile.x_mm[50:], profile.z_mm[50:]) == pytest.approx(0, abs=1e-9)
    # a file of another origin counts x from its innermost point: S1002's table starts
    # 0.10 mm inside the back face, so its thicknesses come out that much thinner (and
    # z = 0 moves along the tread by as much: at most 0.05 mm per mm on a 1:20 slope)
    datum_mm = float(x.min()) if layout.get("x_origin_mm") else 0.0
    z_tolerance_mm = 0.002 + 0.05 * datum_mm
    assert profile.z_offset_mm == pytest.approx(layout.get("z_offset_mm", 0.0), abs=z_tolerance_mm)
    result = handheld_parameters(profile)
    for key in KEYS:
        expected = getattr(truth, key) - (datum_mm if "thickness" in key else 0.0)
        assert getattr(result.parameters, key) == pytest.approx(expected, abs=0.02), key


@pytest.mark.parametrize(
    "step_mm, quality", [(0.1, "fit"), (0.5, "interpolated"), (1.0, "interpolated")]
)
def test_a_sparse_flank_is_interpolated_and_flagged(step_mm, quality) -> None:
    truth = curve_flange_parameters(*contour_samples("LMA", 0.01))
    profile = read_profile_text(gauge_file(*contour_samples("LMA", step_mm)), suffix=".prr")
    result = handheld_parameters(profile)
    assert result.quality == quality
    assert (result.reason is None) == (quality == "fit")
    for key in KEYS:
        assert getattr(result.parameters, key) == pytest.approx(getattr(truth, key), abs=0.03)


def test_the_header_gives_instrument_date_and_its_own_values() -> None:
    header = (
        "[MiniProf wheel]\nProgramName=MiniProf\nDate=30.11.2026\nTime=08:15:00\n"
        "Sd=32.91\nSh=28.02\nqR=9.71\n"
    )  # a title line before the keys is passed over
    profile = read_profile_text(
        gauge_file(*contour_samples("LMA", 0.5), header=header), suffix="WHL"
    )
    assert profile.instrument == "MiniProf" and profile.measured_on == "30.11.2026 08:15:00"
    assert (profile.instrument_flange_thickness_mm, profile.instrument_flange_height_mm,
            profile.instrument_qr_mm) == (32.91, 28.02, 9.71)  # fmt: skip


def test_csv_of_x_z_with_a_header_row_and_comments_is_read() -> None:
    x, z = contour_samples("S1002", 0.3)
    rows = "\n".join(f"{a:.4f};{b:.4f}" for a, b in zip(x, z, strict=True))
    profile = read_profile_text(f"# gauge: Calipri\nx;z\n{rows}\n", suffix=".csv")
    assert handheld_parameters(profile).parameters.flange_thickness_10_mm == pytest.approx(
        32.50, abs=0.02
    )


@pytest.mark.parametrize(
    "text, suffix, match",
    [
        ("ColumnDef=X,Y\n\n1 2\n", ".dat", "suffix must be"),
        ("ColumnDef=X,Y\n\n1 2\nabc 3\n", ".whl", "line 4 is neither"),
        ("ColumnDef=I,Z\n\n1 2\n", ".whl", "ColumnDef must name X and Y"),
        ("XYPoints=12\n\n" + "1 2\n" * 11, ".whl", "XYPoints says 12 points, the file has 11"),
        ("x,z\n" + "1,2\n" * 9, ".csv", "needs ≥ 10 points, got 9"),
        ("x,z\n1,2\n3\n", ".csv", "line 3 is not an x, z pair"),
    ],
)
def test_broken_files_say_what_is_wrong(text, suffix, match) -> None:
    with pytest.raises((ValueError, ProfileFileError), match=match):
        read_profile_text(text, suffix=suffix)


def test_a_profile_short_of_the_tread_reference_point_is_refused() -> None:
    x, z = contour_samples("LMA", 0.5)
    with pytest.raises(ProfileFileError, match="does not reach the reference point at 70 mm"):
        read_profile_text(gauge_file(x[x < 60], z[x < 60]), suffix=".whl")


def test_a_profile_without_a_flank_crossing_raises_flange_not_found() -> None:
    x, z = contour_samples("LMA", 0.5)
    flat = np.where(x < 40, np.minimum(z, 9.0), z)  # the flange cut below 10 mm
    with pytest.raises(FlangeNotFoundError, match="never crosses z = 12.00 mm"):
        handheld_parameters(read_profile_text(gauge_file(x, flat), suffix=".whl"))


@pytest.mark.parametrize("writer, suffix", [(profile_csv_text, ".csv"), (profile_whl_text, ".whl")])
def test_written_profiles_read_back_within_a_micrometre(writer, suffix) -> None:
    rng = np.random.default_rng(3)
    x = np.sort(rng.uniform(-0.1, 135.0, 2000))
    z = rng.uniform(-8, 30, 2000)
    header = [("Pass", "7"), ("Method", "adaptive")]
    parsed = parse_profile_file(writer(x, z, header), suffix=suffix)
    assert np.max(np.abs(parsed.x_mm - x)) < 1e-3 and np.max(np.abs(parsed.z_mm - z)) < 1e-3
    assert parsed.value("pass") == "7" and parsed.value("Method") == "adaptive"


def test_agreement_is_the_mean_mae_std_and_max_of_the_differences() -> None:
    values = [(28.1, 28.0), (27.9, 28.0), (28.3, 28.0), (None, 28.0)]
    observations = [
        Observation(f"w{i}", "adaptive", "flange_height_mm", v, t)
        for i, (v, t) in enumerate(values)
    ]
    (row,) = summarise_agreement(observations)
    d = np.array([0.1, -0.1, 0.3])
    assert row.n == 3
    assert row.mean_difference_mm == pytest.approx(d.mean())
    assert row.mae_mm == pytest.approx(np.abs(d).mean())
    assert row.std_mm == pytest.approx(d.std(ddof=1))
    assert row.max_error_mm == pytest.approx(0.3)
