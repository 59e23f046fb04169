"""Flange parameters of the reference tables (values in shared/profiles/README.md)."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.profile.flange import (
    FlangeNotFoundError,
    curve_flange_parameters,
    fit_flange_parameters,
)
from pipeline.profile.reference import load_reference_profile

EXPECTED = {
    "LMA": (28.0000, 31.9744, 32.9000, 9.7399),
    "S1002": (27.999999, 31.5732, 32.5001, 10.7941),
}


@pytest.mark.parametrize("name", sorted(EXPECTED))
@pytest.mark.parametrize("estimator", [curve_flange_parameters, fit_flange_parameters])
def test_reference_parameters_to_a_hundredth(name: str, estimator) -> None:
    profile = load_reference_profile(name)
    p = estimator(profile.x_mm, profile.z_mm)
    sh, sd, sd10, qr = EXPECTED[name]
    assert p.flange_height_mm == pytest.approx(sh, abs=0.01)
    assert p.flange_thickness_mm == pytest.approx(sd, abs=0.01)
    assert p.flange_thickness_10_mm == pytest.approx(sd10, abs=0.01)
    assert p.qr_mm == pytest.approx(qr, abs=0.01)


def test_reference_tables_are_in_the_profile_frame() -> None:
    lma = load_reference_profile("LMA")
    assert lma.x_mm[0] == 0.0 and np.all(np.diff(lma.x_mm) > 0)
    assert np.interp(70.0, lma.x_mm, lma.z_mm) == pytest.approx(0.0, abs=1e-9)
    assert not lma.x_mm.flags.writeable


def test_fit_ignores_a_stray_spot_above_the_flange() -> None:
    profile = load_reference_profile("LMA")
    x = np.concatenate([profile.x_mm, np.full(6, 17.0)])
    z = np.concatenate([profile.z_mm, 28.0 + np.linspace(0.3, 0.6, 6)])
    assert fit_flange_parameters(x, z).flange_height_mm == pytest.approx(28.0, abs=0.01)


def test_unknown_reference_name() -> None:
    with pytest.raises(ValueError, match="name must be one of LMA, S1002, got 'XYZ'"):
        load_reference_profile("XYZ")


def test_profile_without_flank_is_not_measurable() -> None:
    x = np.linspace(0, 100, 200)
    with pytest.raises(FlangeNotFoundError, match="flank"):
        curve_flange_parameters(x, np.zeros_like(x))
    with pytest.raises(FlangeNotFoundError, match="no flange: the highest crest is at z = "):
        fit_flange_parameters(x, -((x - 50) ** 2) / 100)  # a crest, but 0 mm high


def test_mismatched_arrays_are_refused() -> None:
    with pytest.raises(ValueError, match="x_mm and z_mm must be 1-D of equal length"):
        fit_flange_parameters(np.zeros(3), np.zeros(4))
