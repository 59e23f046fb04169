"""Pass and wheel reports: CSV, JSON and a PDF a depot would file.

The PDF holds a header (site, pass, time, calibration and pipeline versions), the parameter
table with the fleet limits and alarms, and per wheel the fused profile against its
reference profile (with the Sh/Sd/qR construction points) and overlay thumbnails of the
frames with the extracted centres. Everything is drawn from stored results; nothing is
recomputed.
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass
from typing import Any

import cv2
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from reportlab.lib import colors  # noqa: E402
from reportlab.lib.pagesizes import A4  # noqa: E402
from reportlab.lib.styles import getSampleStyleSheet  # noqa: E402
from reportlab.lib.units import mm  # noqa: E402
from reportlab.platypus import (  # noqa: E402
    Image,
    KeepTogether,
    Paragraph,
    SimpleDocTemplate,
    Spacer,
    Table,
    TableStyle,
)
from sqlalchemy.orm import Session  # noqa: E402

from backend.api.schemas import MethodResult, PassReport, PassSummary, PassWheelRead  # noqa: E402
from backend.services.limits import WHEEL_PROFILES, limits_for  # noqa: E402
from backend.services.pass_wheels import wheel_frames  # noqa: E402
from backend.services.queries import pass_summary, pass_wheels  # noqa: E402
from backend.storage.artefacts import load_artefacts  # noqa: E402
from backend.storage.store import BlobStore  # noqa: E402
from db.models import Frame, Pass, PassWheel  # noqa: E402
from db.types import utc_now  # noqa: E402
from pipeline.archive.pass_archive import decode_frame  # noqa: E402
from pipeline.profile.reference import REFERENCE_PROFILES, load_reference_profile  # noqa: E402

PARAMETERS = (
    ("flange_height_mm", "Sh [mm]"),
    ("flange_thickness_mm", "Sd 12 [mm]"),
    ("flange_thickness_en_mm", "Sd 10 [mm]"),
    ("qr_mm", "qR [mm]"),
    ("back_to_back_mm", "B2B [mm]"),
)
CSV_COLUMNS = (
    "pass_id", "site", "started_at", "vehicle_id", "axle", "side", "wheel_id", "state",
    "method", "status", "reason", *(name for name, _ in PARAMETERS), "alarm_count", "alarms",
    "pipeline_version",
)  # fmt: skip
THUMBNAIL_WIDTH_PX = 360
PROFILE_WIDTH_MM = 118
METHOD_COLOURS = {"adaptive": "#d62728", "steger": "#1f77b4"}


@dataclass(frozen=True, slots=True)
class WheelFigures:
    """What a wheel block of the PDF shows, read from the store."""

    wheel: PassWheelRead
    profiles: dict[str, dict[str, Any]]
    reference_profile: str | None
    thumbnails: list[tuple[str, bytes]]


def report_rows(summary: PassSummary, wheels: list[PassWheelRead]) -> list[dict[str, Any]]:
    """One row per wheel and method (a wheel without results gets one row with its state)."""
    rows = []
    for wheel in wheels:
        base = {
            "pass_id": summary.id,
            "site": summary.site,
            "started_at": summary.started_at.isoformat(),
            "vehicle_id": wheel.vehicle_id,
            "axle": wheel.axle,
            "side": wheel.side,
            "wheel_id": wheel.wheel_id,
            "state": wheel.state,
        }
        if not wheel.results:
            rows.append({**base, "reason": wheel.reason, "alarm_count": 0})
        for result in wheel.results:
            rows.append(
                {
                    **base,
                    "method": result.method,
                    "status": result.status,
                    "reason": result.reason or wheel.reason,
                    **{name: getattr(result, name) for name, _ in PARAMETERS},
                    "alarm_count": len(result.alarms),
                    "alarms": "; ".join(a["message"] for a in result.alarms),
                    "pipeline_version": result.pipeline_version,
                }
            )
    return rows


def report_csv(summary: PassSummary, wheels: list[PassWheelRead]) -> bytes:
    """The wheels of a pass as CSV, one row per wheel and method [mm]."""
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=CSV_COLUMNS, extrasaction="ignore")
    writer.writeheader()
    for row in report_rows(summary, wheels):
        writer.writerow({k: "" if v is None else v for k, v in row.items()})
    return buffer.getvalue().encode("utf-8")


def _profile_png(figures: WheelFigures, width_mm: float) -> Image:
    fig, ax = plt.subplots(figsize=(width_mm / 25.4, width_mm / 25.4 * 0.55), dpi=110)
    name = figures.reference_profile
    if name in REFERENCE_PROFILES:
        reference = load_reference_profile(name)
        ax.plot(reference.x_mm, reference.z_mm, color="0.6", lw=1.2, label=f"reference {name}")
    for method, profile in figures.profiles.items():
        colour = METHOD_COLOURS.get(method, "k")
        ax.plot(
            profile.get("x_mm", []),
            profile.get("z_mm", []),
            ".",
            ms=1.2,
            color=colour,
            label=method,
        )
        for key, point in _construction_points(profile.get("construction", {})):
            ax.plot(*point, "x", color=colour, ms=5)
            if method == "adaptive":
                ax.annotate(key, point, fontsize=6, xytext=(3, 3), textcoords="offset points")
    ax.set_xlabel("x from back face [mm]", fontsize=7)
    ax.set_ylabel("z [mm]", fontsize=7)
    ax.tick_params(labelsize=6)
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=6, loc="lower right")
    buffer = io.BytesIO()
    fig.tight_layout()
    fig.savefig(buffer, format="png")
    plt.close(fig)
    buffer.seek(0)
    return Image(buffer, width=width_mm * mm, height=width_mm * 0.55 * mm)


def _construction_points(construction: dict[str, Any]) -> list[tuple[str, tuple[float, float]]]:
    points = []
    for group, values in construction.items():
        if not isinstance(values, dict):
            continue
        for key, value in values.items():
            if (
                isinstance(value, list | tuple)
                and len(value) == 2
                and all(v is not None for v in value)
            ):
                points.append((f"{group}.{key}", (float(value[0]), float(value[1]))))
    return points


def overlay_thumbnail(frame_png: bytes, points: dict[str, np.ndarray] | None) -> bytes:
    """A frame (8-bit for display) with its centre points drawn on it, downscaled."""
    image = decode_frame(frame_png, "stored frame")
    if image.dtype == np.uint16:
        image = (image >> 8).astype(np.uint8)
    scale = min(1.0, THUMBNAIL_WIDTH_PX / image.shape[1])
    small = cv2.resize(image, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
    colour = cv2.cvtColor(small, cv2.COLOR_GRAY2BGR)
    if points is not None:
        # Pixel centres: point (x, y) of the full frame lands at ((x + 0.5) s - 0.5, ...).
        xs = np.round((points["x"] + 0.5) * scale - 0.5).astype(int)
        ys = np.round((points["y"] + 0.5) * scale - 0.5).astype(int)
        inside = (xs >= 0) & (ys >= 0) & (xs < colour.shape[1]) & (ys < colour.shape[0])
        colour[ys[inside], xs[inside]] = (40, 40, 230)
    ok, buffer = cv2.imencode(".png", colour)
    return buffer.tobytes() if ok else b""


def load_wheel_figures(
    store: BlobStore, wheel: PassWheelRead, measurements: list[Any], frames: list[Any]
) -> WheelFigures:
    """Profiles and thumbnails of one wheel from stored rows and artefacts.

    `measurements` are Measurement rows of the wheel; `frames` its Frame rows.
    """
    profiles = {m.method: m.profile or {} for m in measurements if m.profile}
    reference = next((m.reference_profile for m in measurements if m.reference_profile), None)
    adaptive = next((m for m in measurements if m.method == "adaptive"), None)
    by_frame = {(f.sensor, f.seq): f.artefact_sha256 for f in adaptive.frames} if adaptive else {}
    thumbnails = []
    for frame in frames[:4]:
        sha = by_frame.get((frame.sensor, frame.seq))
        points = load_artefacts(store, sha).points if sha else None
        thumbnails.append(
            (
                f"{frame.sensor} #{frame.seq}",
                overlay_thumbnail(store.get(frame.sha256, ".png"), points),
            )
        )
    return WheelFigures(wheel, profiles, reference, thumbnails)


def _cell(value: float | None) -> str:
    return "–" if value is None else f"{value:.2f}"


def _parameter_table(wheels: list[PassWheelRead], limits: dict[str, dict[str, float]]) -> Table:
    header = [
        "Vehicle",
        "Axle",
        "Side",
        "Method",
        "State",
        *(label for _, label in PARAMETERS),
        "Alarms",
    ]
    data: list[list[Any]] = [header]
    style = [
        ("FONT", (0, 0), (-1, -1), "Helvetica", 7),
        ("FONT", (0, 0), (-1, 0), "Helvetica-Bold", 7),
        ("GRID", (0, 0), (-1, -1), 0.25, colors.grey),
        ("BACKGROUND", (0, 0), (-1, 0), colors.Color(0.9, 0.9, 0.9)),
        ("VALIGN", (0, 0), (-1, -1), "MIDDLE"),
    ]
    for wheel in wheels:
        results: list[MethodResult | None] = [*wheel.results] or [None]
        for result in results:
            row: list[Any] = [wheel.vehicle_id, wheel.axle, wheel.side]
            if result is None:
                row += [
                    "–",
                    wheel.state.replace("_", " "),
                    *["–"] * len(PARAMETERS),
                    wheel.reason or "",
                ]
            else:
                alarmed = {a["parameter"] for a in result.alarms}
                row += [result.method, result.status.replace("_", " ")]
                row += [_cell(getattr(result, name)) for name, _ in PARAMETERS]
                row.append(
                    Paragraph("<br/>".join(a["message"] for a in result.alarms), _small_style())
                )
                for column, (name, _) in enumerate(PARAMETERS, start=5):
                    if name in alarmed or (
                        name == "flange_thickness_en_mm" and "flange_thickness_mm" in alarmed
                    ):
                        style.append(
                            ("TEXTCOLOR", (column, len(data)), (column, len(data)), colors.red)
                        )
            data.append(row)
    limit_rows = [_limit_row(family, values) for family, values in limits.items()]
    for row in limit_rows:
        style.append(("BACKGROUND", (0, len(data)), (-1, len(data)), colors.Color(0.95, 0.95, 1.0)))
        data.append(row)
    table = Table(
        data,
        repeatRows=1,
        colWidths=[20 * mm, 9 * mm, 10 * mm, 15 * mm, 18 * mm] + [14 * mm] * 5 + [37 * mm],
    )
    table.setStyle(TableStyle(style))
    return table


def _limit_row(family: str, v: dict[str, float]) -> list[str]:
    thickness = f"{v['flange_thickness_min_mm']:g}–{v['flange_thickness_max_mm']:g}"
    return [
        f"Limits {family}", "", "", "", "",
        f"{v['flange_height_min_mm']:g}–{v['flange_height_max_mm']:g}",
        thickness if family == "LM" else "",
        thickness if family == "EN" else "",
        f"≥ {v['qr_min_mm']:g}",
        f"{v['back_to_back_min_mm']:g}–{v['back_to_back_max_mm']:g}",
        "",
    ]  # fmt: skip


def _small_style():  # noqa: ANN202 (a reportlab ParagraphStyle)
    style = getSampleStyleSheet()["BodyText"].clone("small")
    style.fontSize, style.leading = 6, 7
    return style


def _header(summary: PassSummary, title: str, generated_at: str) -> list[Any]:
    styles = getSampleStyleSheet()
    lines = [
        f"Site <b>{summary.site}</b> · pass <b>{summary.id}</b> · "
        f"{summary.started_at:%Y-%m-%d %H:%M:%S} UTC",
        f"Direction {summary.direction or '–'} · speed {summary.speed_kmh or 0:.1f} km/h · "
        f"vehicles {', '.join(summary.vehicles) or '–'} · fleet {summary.fleet}",
        f"Calibration version {summary.calibration_version} · wheels measured "
        f"{summary.wheels_measured}/{summary.wheels_total} · not measured "
        f"{summary.wheels_not_measured} · alarms {summary.alarm_count} · "
        f"report generated {generated_at}",
    ]
    return [
        Paragraph(title, styles["Title"]),
        *(Paragraph(line, styles["BodyText"]) for line in lines),
        Spacer(1, 4 * mm),
    ]


def _wheel_block(figures: WheelFigures) -> KeepTogether:
    styles = getSampleStyleSheet()
    wheel = figures.wheel
    state = wheel.state.replace("_", " ")
    title = f"Vehicle {wheel.vehicle_id} · axle {wheel.axle} · {wheel.side} — {state}"
    if wheel.reason:
        title += f" ({wheel.reason})"
    plot = _profile_png(figures, PROFILE_WIDTH_MM) if figures.profiles else ""
    thumbnails = Table(
        [
            [Image(io.BytesIO(png), width=52 * mm, height=30 * mm, kind="proportional")]
            + [Paragraph(label, _small_style())]
            for label, png in figures.thumbnails
        ]
        or [[""]]
    )
    layout = Table([[plot, thumbnails]], colWidths=[(PROFILE_WIDTH_MM + 2) * mm, None])
    layout.setStyle(TableStyle([("VALIGN", (0, 0), (-1, -1), "TOP")]))
    return KeepTogether([Paragraph(title, styles["Heading4"]), layout, Spacer(1, 3 * mm)])


def report_pdf(
    summary: PassSummary,
    wheels: list[PassWheelRead],
    limits: dict[str, dict[str, float]],
    figures: list[WheelFigures],
    *,
    title: str,
    generated_at: str,
) -> bytes:
    """The PDF report: header, parameter table with limits and alarms, wheel blocks."""
    buffer = io.BytesIO()
    document = SimpleDocTemplate(
        buffer, pagesize=A4, leftMargin=12 * mm, rightMargin=12 * mm, topMargin=12 * mm,
        bottomMargin=12 * mm, title=title, author="wheelscan",
    )  # fmt: skip
    story = _header(summary, title, generated_at)
    story.append(_parameter_table(wheels, limits))
    story.append(Spacer(1, 6 * mm))
    story.extend(_wheel_block(f) for f in figures)
    document.build(story)
    return buffer.getvalue()


def _report_frames(session: Session, train_pass: Pass, pass_wheel: PassWheel) -> list[Frame]:
    """The wheel's frames for the PDF thumbnails; none once retention removed them."""
    if train_pass.frames_removed_at is not None:
        return []
    return wheel_frames(session, pass_wheel)


def render_report(
    session: Session,
    store: BlobStore,
    train_pass: Pass,
    fmt: str,
    only: PassWheel | None,
) -> tuple[bytes, str]:
    """The report of a pass (or of its wheel `only`) as "csv", "json" or "pdf", with its
    file name."""
    summary = pass_summary(session, train_pass)
    wheels = pass_wheels(session, train_pass)
    if only is not None:
        wheels = [w for w in wheels if w.wheel_id == only.wheel_id]
    stem = f"wheelscan-pass-{train_pass.id}" + (f"-wheel-{only.wheel_id}" if only else "")
    limits = {f: limits_for(session, train_pass.fleet, f) for f in WHEEL_PROFILES}
    if fmt == "csv":
        return report_csv(summary, wheels), f"{stem}.csv"
    if fmt == "json":
        report = PassReport.model_validate({"pass": summary, "limits": limits, "wheels": wheels})
        return report.model_dump_json(by_alias=True).encode(), f"{stem}.json"
    by_wheel = {pw.wheel_id: pw for pw in train_pass.wheels}
    figures = [
        load_wheel_figures(
            store,
            wheel,
            by_wheel[wheel.wheel_id].measurements,
            _report_frames(session, train_pass, by_wheel[wheel.wheel_id]),
        )
        for wheel in wheels
    ]
    title = "Wheel profile report" if only else "Train pass wheel report"
    generated = f"{utc_now():%Y-%m-%d %H:%M} UTC"
    pdf = report_pdf(summary, wheels, limits, figures, title=title, generated_at=generated)
    return pdf, f"{stem}.pdf"
