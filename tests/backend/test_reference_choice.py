"""Which reference profile (and so which limit set) a measured profile is judged against."""

from __future__ import annotations

import numpy as np

from backend.services.limits import profile_family
from backend.services.results import closest_reference
from pipeline.profile.reference import load_reference_profile


def test_the_measured_rim_width_decides_not_a_stray_point_or_a_short_extent() -> None:
    """A field profile often holds a point beyond its field-side face (another part's
    stripe, a glint), or stops short of it: with the rim width measured the wheel keeps its
    own reference, and the limit set that goes with it."""
    s1002 = np.asarray(load_reference_profile("S1002").x_mm, float)
    lma = np.asarray(load_reference_profile("LMA").x_mm, float)
    beyond = np.append(s1002, s1002[-1] + 8.0)
    short = lma[lma < lma[-1] - 4.0]

    assert closest_reference(beyond) == "LMA" and closest_reference(short) == "S1002"
    assert closest_reference(beyond, float(s1002[-1])) == "S1002"
    assert closest_reference(short, float(lma[-1])) == "LMA"
    assert profile_family(closest_reference(beyond, float(s1002[-1]))) == "EN"


def test_without_a_rim_width_the_profile_extent_decides() -> None:
    x = np.asarray(load_reference_profile("S1002").x_mm, float)

    assert closest_reference(x) == "S1002"
    assert closest_reference(np.append(x, 140.0)) == "LMA"
    assert closest_reference(np.zeros(0)) is None
