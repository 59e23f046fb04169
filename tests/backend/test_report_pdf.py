"""The pass and wheel PDFs as a depot files them: every page rendered and read, no text
over text, the limit set and margins that apply, and the cache by content (ETag).

One simulated pass (one axle, two wheels) measured by the service once per database.
"""

from __future__ import annotations

import io
import os
import threading
import time
from pathlib import Path

import pytest
from reportlab.pdfgen.canvas import Canvas

from backend.services.reports import _write_atomically, prune_report_cache
from pipeline.version import PIPELINE_VERSION
from tests.backend.pdf_checks import (
    overlapping_words,
    pdf_pages,
    pdf_text,
    render_pages,
)
from tests.backend.test_measurement_e2e import client, measured, simulated, tokens

__all__ = ["client", "measured", "simulated", "tokens"]  # the shared measured pass


def fetch_pdf(client, auth, path: str, tmp_path: Path, name: str) -> tuple[Path, object]:
    response = client.get(path, headers=auth("viewer"))
    assert response.status_code == 200, response.text
    assert response.headers["content-type"] == "application/pdf"
    out = tmp_path / name
    out.write_bytes(response.content)
    return out, response


def looked_at(pdf: Path, tmp_path: Path) -> str:
    """Render every page, check no two words overlap; return the text."""
    pages = pdf_pages(pdf)
    assert len(render_pages(pdf, tmp_path / pdf.stem)) == len(pages) >= 1
    for number, page in enumerate(pages, start=1):
        assert overlapping_words(page) == [], f"page {number}"
    return pdf_text(pdf)


def test_the_overlap_check_sees_text_drawn_over_text(tmp_path) -> None:
    buffer = io.BytesIO()
    canvas = Canvas(buffer)
    canvas.drawString(100, 700, "1357–1363")
    canvas.drawString(112, 701, "alarms")
    canvas.drawString(100, 600, "apart")
    canvas.save()
    pdf = tmp_path / "overlap.pdf"
    pdf.write_bytes(buffer.getvalue())
    assert [set(pair) for pair in overlapping_words(pdf_pages(pdf)[0])] == [{"1357–1363", "alarms"}]


def test_signed_values_that_round_to_zero_show_no_sign() -> None:
    """The diff row once printed "-0.00" for a difference of −0.001 mm."""
    from backend.services.report_pdf import signed_text

    assert [signed_text(v, 2) for v in (-0.001, 0.004, 0.0, -0.0)] == ["0.00"] * 4
    assert (signed_text(-0.006, 2), signed_text(0.25, 1), signed_text(-1.234, 3)) == (
        "-0.01",
        "+0.2",
        "-1.234",
    )


def test_the_pass_pdf_has_what_a_depot_files(client, auth, measured, tmp_path) -> None:
    pass_id = measured["pass_id"]
    pdf, _ = fetch_pdf(client, auth, f"/api/passes/{pass_id}/report.pdf", tmp_path, "pass.pdf")
    text = looked_at(pdf, tmp_path)
    pages = len(pdf_pages(pdf))
    for words in (
        "Train pass wheel report", "Site", "Time (UTC)", "Direction", "Speed", "Vehicles",
        "Calibration", "version 1", f"pipeline {PIPELINE_VERSION}",
        "Wheels in alarm and near a limit",
        "All wheels", "Adaptive (thick solid)", "Steger (thin dashed)", "Flange top: Sh",
        "Flank at z = 12 mm: Sd", "Flank at z = 10 mm: Sd EN", "Tread reference point",
        "Reviewed by (name)", "Signature", f"page 1 of {pages}", f"page {pages} of {pages}",
    ):  # fmt: skip
        assert words in text, words
    for code_name in ("sh.flange_top", "qr.upper_point", "sd.flank_point", "Sd 12"):
        assert code_name not in text
    assert text.count("Vehicle V001 · axle 1 ·") == 2  # one section per wheel


def test_the_wheel_pdf_shows_one_wheel_and_its_limit_set(client, auth, measured, tmp_path):
    pass_id = measured["pass_id"]
    wheels = client.get(f"/api/passes/{pass_id}/wheels", headers=auth("viewer")).json()
    wheel = wheels[0]
    family = {"LMA": "LM", "S1002": "EN"}[wheel["results"][0]["reference_profile"]]
    path = f"/api/passes/{pass_id}/wheels/{wheel['wheel_id']}/report.pdf"
    pdf, _ = fetch_pdf(client, auth, path, tmp_path, "wheel.pdf")
    text = looked_at(pdf, tmp_path)
    assert f"{wheel['side']} wheel — limits {family}" in text
    assert f"Limits {family} (apply)" in text
    assert "All wheels" not in text and text.count("wheel — limits") == 1
    assert f"vehicle {wheel['vehicle_id']}, axle {wheel['axle']}, {wheel['side']}" in text
    assert "measured of" not in text  # no pass-level counts in a wheel's report
    other = {"LM": "EN", "EN": "LM"}[family]
    assert f"Limits {other}" not in text


def test_the_pdf_shows_tread_values_per_wheel_and_conicity_per_axle(
    client, auth, measured, tmp_path
) -> None:
    pass_id = measured["pass_id"]
    wheels = client.get(f"/api/passes/{pass_id}/wheels", headers=auth("viewer")).json()
    pdf, _ = fetch_pdf(client, auth, f"/api/passes/{pass_id}/report.pdf", tmp_path, "pass.pdf")
    text = looked_at(pdf, tmp_path)
    header = next(line for line in text.splitlines() if "Sd EN" in line and "Method" in line)
    assert header.split()[-5:] == ["B2B", "Hollow", "δ", "Rim", "Result"]
    shown = 0
    for wheel in wheels:
        adaptive = next(r for r in wheel["results"] if r["method"] == "adaptive")
        row = next(
            line.split()
            for line in text.split("All wheels")[1].splitlines()
            if f" {wheel['side']} " in line and " Adaptive " in line
        )
        for key, digits in (("tread_hollow_mm", 2), ("flange_angle_deg", 1), ("rim_width_mm", 2)):
            value = adaptive[key]
            expected = "–" if value is None else f"{value:.{digits}f}"
            assert expected in row, (key, row)
            shown += value is not None
    assert shown >= 4, "the clean pass measures its treads and flanks"
    family = {"LMA": "LM", "S1002": "EN"}[adaptive["reference_profile"]]
    axles = text.split("Axles")[1].split("Wheels")[0]
    row = next(line for line in axles.splitlines() if "λe" in line)
    conicity = {r["method"]: r["equivalent_conicity"] for r in wheels[0]["results"]}
    assert conicity["adaptive"] is not None
    assert f"{conicity['adaptive']:.3f}" in row and f"≤ 0.4 ({family})" in row
    assert f"{0.4 - conicity['adaptive']:+.3f}" in row and "within limit" in row


def test_margins_follow_the_limits_that_apply(client, auth, measured, tmp_path) -> None:
    pass_id = measured["pass_id"]
    wheel = client.get(f"/api/passes/{pass_id}/wheels", headers=auth("viewer")).json()[0]
    adaptive = next(r for r in wheel["results"] if r["method"] == "adaptive")
    family = {"LMA": "LM", "S1002": "EN"}[adaptive["reference_profile"]]
    limits = next(
        row
        for row in client.get("/api/limits", headers=auth("viewer")).json()
        if row["fleet"] == "default" and row["wheel_profile"] == family
    )
    body = {k: v for k, v in limits.items() if k.endswith("_mm")}
    sh = adaptive["flange_height_mm"]
    path = f"/api/passes/{pass_id}/wheels/{wheel['wheel_id']}/report.pdf"
    for minimum, status, margin in (
        (sh - 0.4, "near limit", "+0.40"),
        (sh + 0.3, "ALARM", "-0.30"),
    ):
        body["flange_height_min_mm"] = round(minimum, 6)
        put = client.put(f"/api/limits/default/{family}", json=body, headers=auth("admin"))
        assert put.status_code == 200, put.text
        pdf, _ = fetch_pdf(client, auth, path, tmp_path, f"{status}.pdf")
        summary = pdf_text(pdf).split("All wheels")[0].split("Wheels in alarm")[1]
        row = next(line for line in summary.splitlines() if " Sh " in f" {line} ")
        assert status in row and margin in row and f"({family})" in row
        assert "open" in row
    client.put(f"/api/limits/default/{family}", json=limits, headers=auth("admin"))


def test_the_pdf_is_cached_by_content_and_revalidated(client, auth, measured, tmp_path):
    pass_id = measured["pass_id"]
    path = f"/api/passes/{pass_id}/report.pdf"
    first, response = fetch_pdf(client, auth, path, tmp_path, "first.pdf")
    etag = response.headers["ETag"]
    second, again = fetch_pdf(client, auth, path, tmp_path, "second.pdf")
    assert again.headers["ETag"] == etag and second.read_bytes() == first.read_bytes()
    held = client.get(path, headers={**auth("viewer"), "If-None-Match": etag})
    assert held.status_code == 304 and held.content == b""
    limits = client.get("/api/limits", headers=auth("viewer")).json()[0]
    body = {k: v for k, v in limits.items() if k.endswith("_mm")}
    body["qr_min_mm"] += 0.5
    family = limits["wheel_profile"]
    assert client.put(f"/api/limits/default/{family}", json=body, headers=auth("admin")).is_success
    changed = client.get(path, headers={**auth("viewer"), "If-None-Match": etag})
    assert changed.status_code == 200 and changed.headers["ETag"] != etag
    body["qr_min_mm"] -= 0.5
    client.put(f"/api/limits/default/{family}", json=body, headers=auth("admin"))


@pytest.mark.parametrize("fmt", ["csv", "json"])
def test_csv_and_json_reports_still_come(client, auth, measured, fmt) -> None:
    response = client.get(f"/api/passes/{measured['pass_id']}/report.{fmt}", headers=auth("viewer"))
    assert response.status_code == 200 and "attachment" in response.headers["content-disposition"]


def test_the_report_cache_keeps_the_newest_pdfs_and_drops_stale_parts(tmp_path) -> None:
    for age_s, name in ((30, "old.pdf"), (20, "mid.pdf"), (10, "new.pdf"), (7200, "x.part"),
                        (5, "fresh.part")):  # fmt: skip
        path = tmp_path / name
        path.write_bytes(b"%PDF")
        stamp = time.time() - age_s
        os.utime(path, (stamp, stamp))
    assert prune_report_cache(tmp_path, keep=2) == 2
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fresh.part", "mid.pdf", "new.pdf"]


def test_concurrent_renders_and_prunes_of_the_cache_never_fail(tmp_path) -> None:
    """Requests write and prune the cache at once: a file one lists, another renames or
    removes (this raised FileNotFoundError, a 500, under the load test)."""
    errors: list[BaseException] = []

    def work(n: int) -> None:
        try:
            for i in range(60):
                _write_atomically(tmp_path / f"{n}-{i}.pdf", b"%PDF-1.4\n" * 100)
                prune_report_cache(tmp_path, keep=1)
        except BaseException as error:  # collected for the assertion
            errors.append(error)

    threads = [threading.Thread(target=work, args=(n,)) for n in range(8)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert errors == []
    assert len(list(tmp_path.glob("*.pdf"))) >= 1
