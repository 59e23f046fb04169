"""The wayside-against-handheld table (the paper's Table 2 form) as CSV and PDF."""

from __future__ import annotations

import csv
import io
from typing import Any

from reportlab.lib.pagesizes import A4
from reportlab.lib.units import mm
from reportlab.platypus import Paragraph, SimpleDocTemplate, Table

from backend.api.schemas import AgreementRead, AgreementRow
from backend.services.margins import REPORTED
from backend.services.report_pdf import MARGIN_PT, grid_table, numbered_canvas, report_styles
from db.types import utc_now

COLUMNS = (
    "wheel_id",
    "parameter",
    "method",
    "n",
    "mean_difference_mm",
    "mae_mm",
    "std_mm",
    "max_error_mm",
)
TITLE = "Wayside against handheld gauge"


def agreement_csv(table: AgreementRead) -> bytes:
    """One row per parameter and method over all wheels (wheel_id empty), then per wheel;
    empty cells where a statistic is undefined."""
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=COLUMNS, extrasaction="ignore")
    writer.writeheader()
    for row in [*table.rows, *table.per_wheel]:
        writer.writerow({k: "" if v is None else v for k, v in row.model_dump().items()})
    return buffer.getvalue().encode("utf-8")


def _cell(value: float | None, signed: bool = False) -> str:
    if value is None:
        return "–"
    return f"{value:+.3f}" if signed else f"{value:.3f}"


def _table(rows: list[AgreementRow], names: dict[str, str], *, with_wheel: bool) -> Table:
    head = ["Parameter", "Method", "n", "Mean difference", "MAE", "Std", "Max error"]
    data: list[list[Any]] = [(["Wheel"] if with_wheel else []) + head]
    for row in rows:
        data.append([
            *([row.wheel_id] if with_wheel else []), names.get(row.parameter, row.parameter),
            row.method.capitalize(), row.n, _cell(row.mean_difference_mm, signed=True),
            _cell(row.mae_mm), _cell(row.std_mm), _cell(row.max_error_mm),
        ])  # fmt: skip
    widths = [15, 32, 22, 10, 28, 25, 25, 25] if with_wheel else [40, 25, 12, 30, 25, 25, 25]
    return grid_table(data, widths, [])


def agreement_pdf(table: AgreementRead) -> bytes:
    """The tables as PDF, with how they were formed."""
    s = report_styles()
    names = {p.key: p.label for p in REPORTED}
    generated = f"{utc_now():%Y-%m-%d %H:%M} UTC"
    story = [
        Paragraph(TITLE, s["title"]),
        Paragraph(
            f"{table.pairs} wheel result(s) paired with the handheld reference of the same "
            "wheel measured nearest in time. Differences are wayside − handheld in mm; Std of "
            f"the differences (n − 1). Generated {generated}.",
            s["body"],
        ),
        Paragraph("All wheels (Table 2 form)", s["h2"]),
        _table(table.rows, names, with_wheel=False),
    ]
    if table.per_wheel:
        story += [
            Paragraph("Per wheel over its passes (Tables 3–4 form)", s["h2"]),
            _table(table.per_wheel, names, with_wheel=True),
        ]
    buffer = io.BytesIO()
    document = SimpleDocTemplate(
        buffer, pagesize=A4, leftMargin=MARGIN_PT, rightMargin=MARGIN_PT, topMargin=12 * mm,
        bottomMargin=14 * mm, title=TITLE, author="wheelscan",
    )  # fmt: skip
    document.build(story, canvasmaker=numbered_canvas(f"{TITLE} · {generated}"))
    return buffer.getvalue()
