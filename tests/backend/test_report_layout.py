"""The PDF layout on wheels the simulated pass does not give: only Steger measured, and
nothing measured (no profile, so no limit set can be told)."""

from __future__ import annotations

from collections import Counter
from datetime import UTC, datetime
from pathlib import Path

from backend.api.schemas import MethodResult, PassSummary, PassWheelRead
from backend.services.limits import DEFAULT_LIMITS_MM
from backend.services.margins import limit_margins
from backend.services.report_pdf import (
    WHEEL_COLUMNS,
    ReportHeader,
    WheelSection,
    limit_text,
    render_pdf,
)
from tests.backend.pdf_checks import overlapping_words, pdf_pages, pdf_text, render_pages


def result(method: str, **values: float | None) -> MethodResult:
    measured = bool(values)
    return MethodResult(
        method=method, status="measured" if measured else "not_measured",
        reason=None if measured else "too few profile points on the flank near z = 12.00 mm",
        flange_height_mm=values.get("sh"), flange_thickness_mm=values.get("sd"),
        flange_thickness_10_mm=values.get("sd_en"), qr_mm=values.get("qr"),
        back_to_back_mm=None, reference_profile="LMA" if measured else None,
        sigma_mean_px=None, sigma_min_px=None, sigma_max_px=None, point_count=0, quality={},
        alarms=[], pipeline_version="test",
    )  # fmt: skip


def wheel(wheel_id: int, side: str, results: list[MethodResult]) -> PassWheelRead:
    measured = any(r.status == "measured" for r in results)
    return PassWheelRead(
        wheel_id=wheel_id, vehicle_id="V9", axle=1, side=side,
        state="measured" if measured else "not_measured",
        reason=None if measured else "no method measured a profile", missing_sensors=[],
        frames={}, results=results, alarm_count=0,
    )  # fmt: skip


def pass_pdf(sections: list[WheelSection], pdf: Path) -> Path:
    """The pass PDF of one axle's `sections` (fleet default limits, 10 % amber), at `pdf`."""
    measured = sum(any(r.status == "measured" for r in x.wheel.results) for x in sections)
    summary = PassSummary(
        id=9, site="s", started_at=datetime(2026, 11, 30, 8, tzinfo=UTC), direction=None,
        speed_kmh=None, fleet="default", source="upload", state="closed",
        calibration_version=1, vehicles=["V9"], wheels_total=len(sections),
        wheels_measured=measured, wheels_not_measured=len(sections) - measured, alarm_count=0,
        job=None,
    )  # fmt: skip
    header = ReportHeader("Train pass wheel report", False, "now", "0.1.0", "test")
    amber = {"EN": 0.1, "LM": 0.1}
    pdf.write_bytes(render_pdf(summary, sections, DEFAULT_LIMITS_MM, amber, header))
    return pdf


def test_a_steger_only_wheel_is_summarised_and_an_unmeasured_one_has_no_limit_set(tmp_path):
    lm = DEFAULT_LIMITS_MM["LM"]
    steger = result("steger", sh=25.4, sd=30.0, sd_en=31.0, qr=9.0)
    only_steger = wheel(1, "left", [result("adaptive"), steger])
    nothing = wheel(2, "right", [result("adaptive"), result("steger")])
    margins = {"steger": limit_margins(steger.model_dump(), lm, "LM")}
    sections = [
        WheelSection(only_steger, "LM", lm, margins, None),
        WheelSection(nothing, None, {}, {}, None),
    ]
    pdf = pass_pdf(sections, tmp_path / "layout.pdf")
    assert len(render_pages(pdf, tmp_path / "pages")) == len(pdf_pages(pdf))
    assert all(overlapping_words(page) == [] for page in pdf_pages(pdf))
    text = pdf_text(pdf)
    summary_text = text.split("All wheels")[0]
    row = next(line for line in summary_text.splitlines() if " Sh " in f" {line} ")
    assert row.split()[4:6] == ["–", "25.40"]  # no adaptive value; Steger's
    assert "min 25 (LM)" in row and "+0.40" in row
    assert "near limit" in summary_text and "(Steger)" in summary_text
    assert "right wheel — no profile, no limit set" in text
    assert text.count("(apply)") == 1  # only the measured wheel's limit set


def test_the_full_tables_limit_rows_keep_their_words_whole(tmp_path):
    """The 10 mm columns once broke "27.5–36" into "27.5–3" / "6" and "not checked" into
    "not che" / "cked"."""
    wheels = [
        wheel(1, "left", [result("adaptive", sh=28.0, sd=31.0, sd_en=32.0, qr=9.0)]),
        wheel(2, "right", [result("adaptive", sh=29.0, sd=30.0, sd_en=31.0, qr=9.5)]),
    ]
    sections = [
        WheelSection(w, family, DEFAULT_LIMITS_MM[family], {}, None)
        for w, family in zip(wheels, ("LM", "EN"), strict=True)
    ]
    pdf = pass_pdf(sections, tmp_path / "limits.pdf")
    words = [word for page in pdf_pages(pdf) for word in page.words]
    expected: Counter[str] = Counter()
    for family in ("EN", "LM"):  # its row in the full table and in its wheel's section
        for parameter in WHEEL_COLUMNS:
            text = limit_text(DEFAULT_LIMITS_MM[family], parameter, family)
            expected.update(
                2 * [w for w in text.split() if w == "checked" or any(c.isdigit() for c in w)]
            )
    assert expected["27.5–36"] == 2 and expected["checked"] == 4
    for word, count in expected.items():
        assert words.count(word) >= count, word
