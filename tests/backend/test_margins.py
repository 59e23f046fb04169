"""Margins of a result against the limit set that applies: nearer bound, sign, status (near:
within the inner 10 % of the band by default)."""

from __future__ import annotations

import pytest

from backend.services.limits import DEFAULT_LIMITS_MM
from backend.services.margins import PARAMETERS, REPORTED, limit_margins
from backend.services.results import PARAMETER_NAMES


@pytest.mark.parametrize(
    "family, values, expected",
    [
        ("EN", {"flange_height_mm": 27.9, "flange_thickness_10_mm": 30.0, "qr_mm": 9.0},
         {"flange_height_mm": ("min", 0.4, "near"), "flange_thickness_10_mm": ("max", 3.0, "ok"),
          "qr_mm": ("min", 2.5, "ok")}),
        # LM Sd band 23–34 mm: 1.2 mm inside is 10.9 % of it (ok), 0.9996 mm is 9.1 % (near)
        ("LM", {"flange_height_mm": 33.2, "flange_thickness_mm": 24.2, "qr_mm": 6.4},
         {"flange_height_mm": ("max", -0.2, "alarm"), "flange_thickness_mm": ("min", 1.2, "ok"),
          "qr_mm": ("min", -0.1, "alarm")}),
        ("LM", {"flange_thickness_mm": 23.9996},
         {"flange_thickness_mm": ("min", 0.9996, "near")}),
        ("LM", {"back_to_back_mm": 1355.5, "flange_thickness_10_mm": 20.0},
         {"back_to_back_mm": ("max", 0.5, "near")}),
    ],
)  # fmt: skip
def test_margins_take_the_nearer_bound_of_the_set_that_applies(family, values, expected):
    margins = limit_margins(values, DEFAULT_LIMITS_MM[family], family)
    got = {m.parameter: (m.bound, m.margin_mm, m.status) for m in margins}
    assert got.keys() == expected.keys()
    for name, (bound, margin, status) in expected.items():
        assert got[name][0] == bound and got[name][2] == status, name
        assert got[name][1] == pytest.approx(margin), name


def test_the_reports_list_every_stored_parameter_once_and_checks_only_those_with_limits():
    assert sorted(p.key for p in REPORTED) == sorted(PARAMETER_NAMES)
    assert [p for p in REPORTED if p.families] == list(PARAMETERS)
    unchecked = {"tread_hollow_mm": 0.4, "flange_angle_deg": 70.0, "rim_width_mm": 135.0}
    assert limit_margins(unchecked, DEFAULT_LIMITS_MM["EN"], "EN") == []
