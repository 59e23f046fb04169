"""The PDF a depot files for a pass (or one wheel of it), laid out with reportlab.

Order: header (site, pass, time UTC, direction, speed, vehicles, calibration, software and
pipeline versions); the wheels in alarm or near a limit, with the limit set that applies,
the margin and the disposition; the full table; one compact section per wheel (profile
against reference with its constructions in words, both methods, the limits that apply);
a reviewer block. Every page carries "page x of y". Terms and units are the web app's,
from the one parameter list (`margins.REPORTED`): Sh, Sd (at 12 mm), Sd EN (at 10 mm), qR,
B2B, tread hollow, rim width in mm, the flange angle δ in degrees, and the axle's equivalent
conicity λe (no unit) once per axle.
"""

from __future__ import annotations

import io
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from reportlab.graphics.shapes import Drawing
from reportlab.lib import colors
from reportlab.lib.pagesizes import A4
from reportlab.lib.styles import ParagraphStyle, getSampleStyleSheet
from reportlab.lib.units import mm
from reportlab.pdfgen.canvas import Canvas
from reportlab.platypus import (
    CondPageBreak,
    KeepTogether,
    Paragraph,
    SimpleDocTemplate,
    Spacer,
    Table,
    TableStyle,
)

from backend.api.schemas import MethodResult, PassSummary, PassWheelRead
from backend.services.margins import REPORTED, Margin, Parameter
from backend.services.review import disposition_text
from pipeline.profile.flange import missing_value_names

WHEEL_COLUMNS = tuple(p for p in REPORTED if not p.per_axle)
"""The values of a wheel's table row, in `REPORTED` order."""
AXLE_VALUES = tuple(p for p in REPORTED if p.per_axle)
"""The values shown once per axle (the equivalent conicity)."""
BY_KEY = {p.key: p for p in REPORTED}
TERMS = (
    "Sh flange height above the tread reference point; Sd flange thickness at z = 12 mm "
    "(LM limits), Sd EN at z = 10 mm (EN limits), both from the back face; qR from the flank "
    "at Sh − 2 mm to the flank at z = 10 mm; B2B back-to-back distance of the axle; Hollow "
    "tread hollow below a straight edge at x = 60 and 120 mm; δ steepest flank angle over 10 mm "
    "of height [°]; "
    "Rim rim width, back face to field face, where the outer sensor sees it. In mm but δ. "
    "λe the axle's equivalent conicity at 3 mm amplitude (EN 15302), no unit."
)
RED_HEX, AMBER_HEX = "#b71c1c", "#e65100"
RED, AMBER = colors.HexColor(RED_HEX), colors.HexColor(AMBER_HEX)
HEAD = colors.Color(0.9, 0.9, 0.9)
MARGIN_PT = 14 * mm
HEADING_ROOM_PT = 35 * mm
WHEEL_SECTION_PT = 95 * mm
"""A wheel's section with its plot (kept together): the room the "Wheels" heading needs."""
WIDTH_PT = A4[0] - 2 * MARGIN_PT


@dataclass(frozen=True, slots=True)
class WheelSection:
    """What the report shows of one wheel: its record, its limit set and the plot."""

    wheel: PassWheelRead
    family: str | None
    """EN or LM; None where no method measured a profile (no limit set can be told)."""
    limits_mm: dict[str, float]
    margins: dict[str, list[Margin]]
    """Per method, the margins of its checked parameters."""
    drawing: Drawing | None


@dataclass(frozen=True, slots=True)
class ReportHeader:
    """The identifying lines of a report."""

    title: str
    wheel_report: bool
    """One wheel's report (its one section), not the pass's."""
    generated_at: str
    software_version: str
    pipeline_versions: str


def report_styles() -> dict[str, ParagraphStyle]:
    base = getSampleStyleSheet()
    body = ParagraphStyle("body", parent=base["BodyText"], fontSize=8, leading=10)
    return {
        "title": ParagraphStyle("title", parent=base["Title"], fontSize=15, spaceAfter=2 * mm),
        "h2": ParagraphStyle("h2", parent=base["Heading2"], fontSize=11, spaceBefore=3 * mm),
        "h3": ParagraphStyle("h3", parent=base["Heading4"], fontSize=9, spaceAfter=1 * mm),
        "body": body,
        "small": ParagraphStyle("small", parent=body, fontSize=6.5, leading=8),
        # limits in the full table's 10 mm columns: "27.5–36" on one line, words unbroken
        "limit": ParagraphStyle("limit", parent=body, fontSize=6, leading=7.5, splitLongWords=0),
    }


def heading(text: str, s: dict[str, ParagraphStyle], room_pt: float = HEADING_ROOM_PT) -> list[Any]:
    """A section heading, on a new page where less than `room_pt` is left below it (no
    heading alone at a page's foot; a long table after it still starts on its page)."""
    return [CondPageBreak(room_pt), Paragraph(text, s["h2"])]


def grid_table(data: list[list[Any]], widths_mm: Sequence[float], extra: list[Any]) -> Table:
    table = Table(data, colWidths=[w * mm for w in widths_mm], repeatRows=1)
    table.setStyle(
        TableStyle(
            [
                ("FONT", (0, 0), (-1, -1), "Helvetica", 7),
                ("FONT", (0, 0), (-1, 0), "Helvetica-Bold", 7),
                ("GRID", (0, 0), (-1, -1), 0.25, colors.grey),
                ("BACKGROUND", (0, 0), (-1, 0), HEAD),
                ("VALIGN", (0, 0), (-1, -1), "MIDDLE"),
                ("TOPPADDING", (0, 0), (-1, -1), 1.5),
                ("BOTTOMPADDING", (0, 0), (-1, -1), 1.5),
                ("LEFTPADDING", (0, 0), (-1, -1), 2.5),
                ("RIGHTPADDING", (0, 0), (-1, -1), 2.5),
                *extra,
            ]
        )
    )
    return table


def _number(value: float | None, parameter: Parameter) -> str:
    return "–" if value is None else f"{value:.{parameter.digits}f}"


def signed_text(value: float, digits: int) -> str:
    """`value` with its sign at `digits` decimals; one that rounds to zero shows none ("0.00",
    never "-0.00" or "+0.00")."""
    text = f"{abs(value):.{digits}f}"
    if float(text) == 0:
        return text
    return ("+" if value > 0 else "-") + text


def limit_text(limits: dict[str, float], parameter: Parameter, family: str) -> str:
    """'min–max', '≥ min' or '≤ max' of one parameter in a limit set; 'not checked' where
    the set does not check it, 'no limit' for a value shown without one."""
    if not parameter.families:
        return "no limit"
    if family not in parameter.families:
        return "not checked"
    low = limits.get(parameter.bound_field("min"))
    high = limits.get(parameter.bound_field("max"))
    if low is not None and high is not None:
        return f"{low:g}–{high:g}"
    return f"≥ {low:g}" if low is not None else f"≤ {high:g}" if high is not None else "–"


def amber_text(near_limit_fractions: dict[str, float], families: Sequence[str]) -> str:
    """The fleet's amber band in words: "the inner 10 %" (per limit set where they differ)."""
    shown = {f: f"{100 * near_limit_fractions[f]:g} %" for f in families}
    if len(set(shown.values())) <= 1:
        return f"the inner {next(iter(shown.values()), '–')}"
    return "the inner " + ", ".join(f"{v} ({f})" for f, v in shown.items())


def _header_block(
    summary: PassSummary, header: ReportHeader, wheel: PassWheelRead | None, s: dict
) -> list[Any]:
    """The identification table; the wheel report names its wheel instead of the pass's
    counts."""
    if wheel is None:
        counted = ("Wheels", f"{summary.wheels_measured} measured of {summary.wheels_total}, "
                   f"{summary.wheels_not_measured} not measured")  # fmt: skip
    else:
        state = wheel.state.replace("_", " ")
        counted = ("Wheel", f"vehicle {wheel.vehicle_id}, axle {wheel.axle}, {wheel.side} "
                   f"(id {wheel.wheel_id}): {state}")  # fmt: skip
    rows = [
        ("Site", summary.site, "Pass", f"#{summary.id} ({summary.source}, fleet {summary.fleet})"),
        ("Time (UTC)", f"{summary.started_at:%Y-%m-%d %H:%M:%S}", "Direction",
         summary.direction or "–"),
        ("Speed", "–" if summary.speed_kmh is None else f"{summary.speed_kmh:.1f} km/h",
         "Vehicles", ", ".join(summary.vehicles) or "–"),
        ("Calibration", f"version {summary.calibration_version}", "Software",
         f"wheelscan {header.software_version}, pipeline {header.pipeline_versions}"),
        (*counted, "Report generated", header.generated_at),
    ]  # fmt: skip
    data = [[Paragraph(f"<b>{k1}</b>", s["small"]), Paragraph(v1, s["body"]),
             Paragraph(f"<b>{k2}</b>", s["small"]), Paragraph(v2, s["body"])]
            for k1, v1, k2, v2 in rows]  # fmt: skip
    table = Table(data, colWidths=[24 * mm, 63 * mm, 27 * mm, 68 * mm])
    table.setStyle(
        TableStyle(
            [
                ("GRID", (0, 0), (-1, -1), 0.25, colors.grey),
                ("BACKGROUND", (0, 0), (0, -1), HEAD),
                ("BACKGROUND", (2, 0), (2, -1), HEAD),
                ("VALIGN", (0, 0), (-1, -1), "MIDDLE"),
            ]
        )
    )
    return [Paragraph(header.title, s["title"]), table, Spacer(1, 2 * mm)]


def _result(wheel: PassWheelRead, method: str) -> MethodResult | None:
    return next((r for r in wheel.results if r.method == method), None)


def _attention(sections: list[WheelSection], amber: str, s: dict) -> list:
    """Wheels in alarm, then near a limit (adaptive margins; Steger's value beside); an
    axle's value (λe) once per axle."""
    rows = []
    seen: set[tuple[str, int, str]] = set()
    for section in sections:
        w = section.wheel
        # the adaptive result, which the alarms follow; Steger's where adaptive measured none
        method = "adaptive" if section.margins.get("adaptive") else "steger"
        other = _result(w, "steger" if method == "adaptive" else "adaptive")
        for margin in section.margins.get(method, []):
            axle = (w.vehicle_id, w.axle, margin.parameter)
            if margin.status == "ok" or (BY_KEY[margin.parameter].per_axle and axle in seen):
                continue
            seen.add(axle)
            other_mm = None if other is None else getattr(other, margin.parameter)
            rows.append((margin, section, method, other_mm))
    rows.sort(key=lambda r: (r[0].status != "alarm", r[0].margin_mm))
    story: list[Any] = heading("Wheels in alarm and near a limit", s)
    if not rows:
        story.append(Paragraph("No wheel is in alarm or near a limit.", s["body"]))
        return story
    head = ["Vehicle", "Axle", "Side", "Parameter", "Adaptive", "Steger", "Limit (set)",
            "Margin", "Status", "Disposition"]  # fmt: skip
    data: list[list[Any]] = [head]
    extra = []
    for margin, section, method, other_mm in rows:
        w, parameter = section.wheel, BY_KEY[margin.parameter]
        alarm = margin.status == "alarm"
        word = ("below" if margin.bound == "min" else "above") if alarm else margin.bound
        disposition = Paragraph(disposition_text(w.disposition), s["small"])
        values = [_number(margin.value_mm, parameter), _number(other_mm, parameter)]
        status = ("ALARM" if alarm else "near limit") + (
            "" if method == "adaptive" else " (Steger)"
        )
        hex_colour = RED_HEX if alarm else AMBER_HEX
        status_cell = Paragraph(f'<font color="{hex_colour}">{status}</font>', s["small"])
        data.append([
            w.vehicle_id, w.axle, "axle" if parameter.per_axle else w.side, parameter.label,
            *(values if method == "adaptive" else values[::-1]),
            f"{word} {margin.limit_mm:g} ({section.family})",
            signed_text(margin.margin_mm, parameter.digits),
            status_cell, disposition,
        ])  # fmt: skip
        colour = RED if margin.status == "alarm" else AMBER
        extra.append(("TEXTCOLOR", (4, len(data) - 1), (8, len(data) - 1), colour))
    story.append(grid_table(data, [17, 9, 10, 13, 14, 14, 27, 13, 17, 48], extra))
    story.append(
        Paragraph(
            "Margin: distance inside the limit (negative outside) of the adaptive result, the "
            "method the alarms follow, or of Steger's where adaptive measured nothing. Near a "
            f"limit: inside by less than {amber} of its limit band (the fleet's amber band). "
            "Disposition: the operator's decision in force, who recorded it and when (UTC); "
            "open where there is none.",
            s["small"],
        )
    )
    return story


def _cells(result: MethodResult | None) -> list[str]:
    if result is None:
        return ["–"] * len(WHEEL_COLUMNS)
    return [_number(getattr(result, p.key), p) for p in WHEEL_COLUMNS]


def _status(result: MethodResult | None, wheel: PassWheelRead, brief: bool = False) -> str:
    """A result's cell: not measured and why, or its alarms or "within limits" and the values
    it lacks, with their reasons (`brief`: their names only, as in the pass table)."""
    if result is None:
        return wheel.state.replace("_", " ") + (f": {wheel.reason}" if wheel.reason else "")
    if result.status != "measured":
        return f"not measured: {result.reason or wheel.reason or '–'}"
    status = f"{len(result.alarms)} alarm(s)" if result.alarms else "within limits"
    # a measured result's reason names the values it lacks ("Sd 10: …; qR: …")
    if result.reason is None:
        return status
    missing = ", ".join(missing_value_names(result.reason)) if brief else result.reason
    return f"{status}; not measured: {missing}"


def _colours(row: int, margins: list[Margin], first_column: int) -> list[Any]:
    """Red (alarm) and orange (near) cells of one table row; parameters from first_column."""
    columns = {p.key: i for i, p in enumerate(WHEEL_COLUMNS)}
    out: list[tuple[Any, ...]] = []
    for margin in margins:
        if margin.status == "ok" or margin.parameter not in columns:
            continue
        column = first_column + columns[margin.parameter]
        colour = RED if margin.status == "alarm" else AMBER
        out.append(("TEXTCOLOR", (column, row), (column, row), colour))
        out.append(("FONT", (column, row), (column, row), "Helvetica-Bold", 7))
    return out


def _limit_cells(limits: dict[str, float], family: str, s: dict) -> list[Any]:
    return [Paragraph(limit_text(limits, p, family), s["limit"]) for p in WHEEL_COLUMNS]


def _full_table(
    sections: list[WheelSection], all_limits: dict[str, dict], amber: str, s: dict
) -> list:
    head = ["Vehicle", "Axle", "Side", "Limits", "Method", *(p.label for p in WHEEL_COLUMNS),
            "Result"]  # fmt: skip
    data: list[list[Any]] = [head]
    extra: list[Any] = []
    for section in sections:
        w = section.wheel
        for method in ("adaptive", "steger"):
            result = _result(w, method)
            margins = section.margins.get(method, [])
            data.append([w.vehicle_id, w.axle, w.side, section.family or "–", method.capitalize(),
                         *_cells(result),
                         Paragraph(_status(result, w, brief=True), s["small"])])  # fmt: skip
            extra += _colours(len(data) - 1, margins, 5)
    used = sorted({section.family for section in sections if section.family})
    for family in used:
        limits = all_limits[family]
        row = [f"Limits {family}", "", "", family, "", *_limit_cells(limits, family, s), ""]
        extra.append(("BACKGROUND", (0, len(data)), (-1, len(data)), colors.Color(0.94, 0.95, 1)))
        extra.append(("SPAN", (0, len(data)), (2, len(data))))
        data.append(row)
    return [
        *heading("All wheels", s),
        grid_table(data, [13, 7, 8, 9, 13, 10, 10, 11, 10, 14, 11, 8, 11, 47], extra),
        Paragraph(
            f"{TERMS} Red: outside its limit; orange: within {amber} of its band.", s["small"]
        ),
    ]


STATUS_WORDS = {"alarm": "ALARM", "near": "near limit", "ok": "within limit"}


def _axle_row(section: WheelSection, parameter: Parameter) -> tuple[list[Any], Margin | None]:
    """One per-axle value of an axle (from one of its wheels' sections), and its margin."""
    w, family = section.wheel, section.family
    values = [_number(None if r is None else getattr(r, parameter.key), parameter)
              for r in (_result(w, "adaptive"), _result(w, "steger"))]  # fmt: skip
    margins = section.margins.get("adaptive", [])
    margin = next((m for m in margins if m.parameter == parameter.key), None)
    limit = f"{limit_text(section.limits_mm, parameter, family)} ({family})" if family else "–"
    row = [w.vehicle_id, w.axle, parameter.label, *values, limit]
    if margin is None:
        return [*row, "–", "not computed"], None
    return [
        *row,
        signed_text(margin.margin_mm, parameter.digits),
        STATUS_WORDS[margin.status],
    ], margin


def _axle_table(sections: list[WheelSection], s: dict) -> list[Any]:
    """The per-axle values (λe) of each axle, adaptive and Steger, with the limit that
    applies and the adaptive margin."""
    axles: dict[tuple[str, int], WheelSection] = {}
    for section in sections:
        key = (section.wheel.vehicle_id, section.wheel.axle)
        if key not in axles or axles[key].family is None:
            axles[key] = section
    head = ["Vehicle", "Axle", "Value", "Adaptive", "Steger", "Limit (set)", "Margin", "Status"]
    data: list[list[Any]] = [head]
    extra: list[Any] = []
    for section in axles.values():
        for parameter in AXLE_VALUES:
            row, margin = _axle_row(section, parameter)
            data.append(row)
            if margin is not None and margin.status != "ok":
                colour = RED if margin.status == "alarm" else AMBER
                extra.append(("TEXTCOLOR", (3, len(data) - 1), (7, len(data) - 1), colour))
    return [
        *heading("Axles", s),
        grid_table(data, [20, 10, 14, 20, 20, 40, 20, 38], extra),
        Paragraph(
            "λe: the axle's equivalent conicity at 3 mm amplitude (EN 15302, nonlinear method) "
            "from both wheels' measured profiles at their back-to-back distance on the site's "
            "rails; no unit. Not computed where either wheel or the back-to-back distance was "
            "not measured.",
            s["small"],
        ),
    ]


def _wheel_table(section: WheelSection, s: dict) -> Table:
    w, family = section.wheel, section.family
    adaptive, steger = _result(w, "adaptive"), _result(w, "steger")
    head = ["", *(p.label for p in WHEEL_COLUMNS), "Result"]
    data: list[list[Any]] = [head]
    extra: list[Any] = []
    for name, result in (("Adaptive", adaptive), ("Steger", steger)):
        data.append([name, *_cells(result), Paragraph(_status(result, w), s["small"])])
        extra += _colours(len(data) - 1, section.margins.get(name.lower(), []), 1)
    differences = []
    for p in WHEEL_COLUMNS:
        a = None if adaptive is None else getattr(adaptive, p.key)
        b = None if steger is None else getattr(steger, p.key)
        differences.append("–" if a is None or b is None else signed_text(a - b, p.digits))
    data.append(["Adaptive − Steger", *differences, ""])
    if family is not None:
        limits = _limit_cells(section.limits_mm, family, s)
        data.append([f"Limits {family} (apply)", *limits, ""])
    return grid_table(data, [27, 14, 14, 14, 14, 16, 14, 12, 14, 43], extra)


def _wheel_block(section: WheelSection, s: dict) -> KeepTogether:
    w = section.wheel
    title = f"Vehicle {w.vehicle_id} · axle {w.axle} · {w.side} wheel — " + (
        f"limits {section.family}" if section.family else "no profile, no limit set"
    )
    parts: list[Any] = [Paragraph(title, s["h3"])]
    if section.drawing is not None:
        parts.append(section.drawing)
    else:
        parts.append(
            Paragraph(f"No profile to draw ({w.reason or 'no stored points'}).", s["body"])
        )
    parts += [
        Spacer(1, 1 * mm),
        _wheel_table(section, s),
        Paragraph(f"<b>Disposition</b>: {disposition_text(w.disposition)}", s["body"]),
        Spacer(1, 4 * mm),
    ]
    return KeepTogether(parts)


def _signature(s: dict) -> list[Any]:
    data = [
        ["Reviewed by (name)", "", "Date", ""],
        ["Signature", "", "Disposition of the alarms", ""],
    ]
    table = Table(data, colWidths=[34 * mm, 58 * mm, 38 * mm, 52 * mm], rowHeights=12 * mm)
    table.setStyle(
        TableStyle(
            [
                ("FONT", (0, 0), (-1, -1), "Helvetica", 8),
                ("GRID", (0, 0), (-1, -1), 0.5, colors.black),
                ("BACKGROUND", (0, 0), (0, -1), HEAD),
                ("BACKGROUND", (2, 0), (2, -1), HEAD),
                ("VALIGN", (0, 0), (-1, -1), "MIDDLE"),
            ]
        )
    )
    return [KeepTogether([Paragraph("Review", s["h2"]), table])]


def numbered_canvas(footer: str) -> type[Canvas]:
    class NumberedCanvas(Canvas):
        """Holds every page until the end, then stamps 'page x of y' on each."""

        def __init__(self, *args: Any, **kwargs: Any) -> None:
            super().__init__(*args, **kwargs)
            self._pages: list[dict[str, Any]] = []

        def showPage(self) -> None:  # noqa: N802 (reportlab's name)
            self._pages.append(dict(self.__dict__))
            self._startPage()

        def save(self) -> None:
            for number, page in enumerate(self._pages, start=1):
                self.__dict__.update(page)
                self.setFont("Helvetica", 7)
                self.drawString(MARGIN_PT, 8 * mm, footer)
                self.drawRightString(
                    A4[0] - MARGIN_PT, 8 * mm, f"page {number} of {len(self._pages)}"
                )
                super().showPage()
            super().save()

    return NumberedCanvas


def render_pdf(
    summary: PassSummary,
    sections: list[WheelSection],
    all_limits: dict[str, dict[str, float]],
    near_limit_fractions: dict[str, float],
    header: ReportHeader,
) -> bytes:
    """The PDF of a pass (all its wheel sections) or of one wheel (one section); the
    fleet's amber band of each limit set (`near_limit_fractions`) is named in words."""
    s = report_styles()
    buffer = io.BytesIO()
    document = SimpleDocTemplate(
        buffer, pagesize=A4, leftMargin=MARGIN_PT, rightMargin=MARGIN_PT, topMargin=12 * mm,
        bottomMargin=14 * mm, title=header.title, author="wheelscan",
    )  # fmt: skip
    story = _header_block(summary, header, sections[0].wheel if header.wheel_report else None, s)
    used = sorted({section.family for section in sections if section.family})
    amber = amber_text(near_limit_fractions, used)
    story += _attention(sections, amber, s)
    if len(sections) > 1:
        story += _full_table(sections, all_limits, amber, s)
    story += _axle_table(sections, s)
    story += heading("Wheels", s, WHEEL_SECTION_PT)
    story += [_wheel_block(section, s) for section in sections]
    story += _signature(s)
    footer = f"{header.title} · site {summary.site} · pass #{summary.id} · {header.generated_at}"
    document.build(story, canvasmaker=numbered_canvas(footer))
    return buffer.getvalue()
