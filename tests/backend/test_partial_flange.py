"""A wheel whose qR cannot be measured keeps its Sh and Sd: the stored constructions leave
qR out and the reason says why (the frontend draws what is there)."""

from __future__ import annotations

import numpy as np

from backend.services.results import construction_points
from pipeline.profile.flange import FlangeParameters
from pipeline.profile.fusion import FusedProfile


def _profile() -> FusedProfile:
    x = np.array([0.0, 10.0, 16.0, 30.0, 70.0])
    z = np.array([-10.0, 20.0, 28.0, 12.0, 0.0])
    return FusedProfile(x, z, np.zeros(5, np.int8), -676.0, 0.0, None, 0, 0)


def test_constructions_without_qr_keep_sh_and_sd() -> None:
    partial = FlangeParameters(28.0, 30.5, 31.4, None, 0.0, "qR: too few profile points")
    points = construction_points(partial, _profile())
    assert set(points) == {"sh", "sd", "sd_en"}
    assert points["sd"]["flank_point"] == [30.5, 12.0]
    full = construction_points(FlangeParameters(28.0, 30.5, 31.4, 9.1), _profile())
    assert full["qr"]["upper_point"] == [22.3, 26.0]
