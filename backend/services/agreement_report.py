"""The wayside-against-handheld table (the paper's Table 2 form) as CSV and PDF."""

from __future__ import annotations

import csv
import io

from reportlab.lib.pagesizes import A4
from reportlab.lib.units import mm
from reportlab.platypus import Paragraph, SimpleDocTemplate

from backend.api.schemas import AgreementRead
from backend.services.report_pdf import (
    MARGIN_PT,
    PARAMETERS,
    grid_table,
    numbered_canvas,
    report_styles,
)
from db.types import utc_now

COLUMNS = ("parameter", "method", "n", "mean_difference_mm", "mae_mm", "std_mm", "max_error_mm")
TITLE = "Wayside against handheld gauge"


def agreement_csv(table: AgreementRead) -> bytes:
    """One row per parameter and method; empty cells where a statistic is undefined."""
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=COLUMNS, extrasaction="ignore")
    writer.writeheader()
    for row in table.rows:
        writer.writerow({k: "" if v is None else v for k, v in row.model_dump().items()})
    return buffer.getvalue().encode("utf-8")


def _cell(value: float | None, signed: bool = False) -> str:
    if value is None:
        return "–"
    return f"{value:+.3f}" if signed else f"{value:.3f}"


def agreement_pdf(table: AgreementRead) -> bytes:
    """A one-page PDF of the table with how it was formed."""
    s = report_styles()
    names = dict(PARAMETERS)
    generated = f"{utc_now():%Y-%m-%d %H:%M} UTC"
    data: list[list[object]] = [
        ["Parameter", "Method", "n", "Mean difference", "MAE", "Std", "Max error"]
    ]
    for row in table.rows:
        data.append([
            names.get(row.parameter, row.parameter), row.method.capitalize(), row.n,
            _cell(row.mean_difference_mm, signed=True), _cell(row.mae_mm), _cell(row.std_mm),
            _cell(row.max_error_mm),
        ])  # fmt: skip
    story = [
        Paragraph(TITLE, s["title"]),
        Paragraph(
            f"{table.pairs} wheel result(s) paired with the handheld reference of the same "
            "wheel measured nearest in time. Differences are wayside − handheld in mm; Std of "
            f"the differences (n − 1). Generated {generated}.",
            s["body"],
        ),
        grid_table(data, [40, 25, 12, 30, 25, 25, 25], []),
    ]
    buffer = io.BytesIO()
    document = SimpleDocTemplate(
        buffer, pagesize=A4, leftMargin=MARGIN_PT, rightMargin=MARGIN_PT, topMargin=12 * mm,
        bottomMargin=14 * mm, title=TITLE, author="wheelscan",
    )  # fmt: skip
    document.build(story, canvasmaker=numbered_canvas(f"{TITLE} · {generated}"))
    return buffer.getvalue()
