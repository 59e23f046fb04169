"""Pass and wheel reports: CSV, JSON and the PDF a depot files, cached by content.

The PDF (layout in `report_pdf`, plots in `report_plot`) is drawn from stored results;
nothing is recomputed but the margins, against the fleet's current limits and amber band.
It is cached on disk under a key of everything it shows (the pass, every result row with
its disposition in force, the limits, the amber band and the software version), which is
also its ETag: a second request, or one after an unrelated change, costs one key and one
file read; a new result or disposition gives a new key and a new PDF.
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
import os
import tempfile
import time
from collections.abc import Iterable
from dataclasses import dataclass
from datetime import UTC
from pathlib import Path
from typing import Any

from sqlalchemy.orm import Session

from backend import __version__
from backend.api.schemas import PassReport, PassSummary, PassWheelRead
from backend.services.limits import (
    WHEEL_PROFILES,
    limits_for,
    profile_family,
    review_thresholds,
)
from backend.services.margins import limit_margins
from backend.services.queries import pass_summary, pass_wheels
from backend.services.report_pdf import ReportHeader, WheelSection, render_pdf
from backend.services.report_plot import Curve, construction_labels, profile_drawing
from backend.services.results import PARAMETER_NAMES
from backend.services.review import DISPOSITION_WORDS
from backend.services.wheel_data import stored_outline
from db.models import Pass, PassWheel
from db.types import utc_now
from pipeline.profile.reference import REFERENCE_PROFILES, load_reference_profile

REPORT_CACHE_FILES = 500
"""PDFs kept in the cache, newest first (a pass PDF is ~250 kB: about 125 MB at most)."""
STALE_PART_S = 3600.0
"""A half-written cache file older than this was left by a killed process."""
REPORT_LAYOUT = "12"
"""Part of the cache key: bump when the PDF's layout changes, so old PDFs are not served."""
CSV_COLUMNS = (
    "pass_id", "site", "started_at", "vehicle_id", "axle", "side", "wheel_id", "state",
    "method", "status", "reason", *PARAMETER_NAMES, "alarm_count", "alarms",
    "pipeline_version", "disposition", "disposition_comment", "disposition_by",
    "disposition_at",
)  # fmt: skip
"""`disposition` is the kind in force in words ("open" where there is none); `_at` in UTC."""


def _disposition_columns(wheel: PassWheelRead) -> dict[str, str | None]:
    d = wheel.disposition
    if d is None:
        return {"disposition": "open"}
    return {
        "disposition": DISPOSITION_WORDS[d.kind],
        "disposition_comment": d.comment,
        "disposition_by": d.actor,
        "disposition_at": d.created_at.astimezone(UTC).isoformat(),
    }


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
            **_disposition_columns(wheel),
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
                    **{name: getattr(result, name) for name in PARAMETER_NAMES},
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


def _section(
    pass_wheel: PassWheel, wheel: PassWheelRead, fleet_limits: dict, amber: dict[str, float]
) -> WheelSection:
    measurements = {m.method: m for m in pass_wheel.measurements}
    reference = next(
        (m.reference_profile for m in measurements.values() if m.reference_profile), None
    )
    family = profile_family(reference) if reference else None
    limits = fleet_limits[family] if family else {}
    margins = {
        r.method: limit_margins(r.model_dump(), limits, family, amber[family])
        for r in wheel.results
        if r.status == "measured" and family
    }
    curves = []
    if reference in REFERENCE_PROFILES:
        table = load_reference_profile(reference)
        curves.append(Curve("reference", table.x_mm, table.z_mm))
    for method, measurement in measurements.items():
        profile = measurement.profile or {}
        if profile.get("x_mm"):
            curves.append(Curve(method, *stored_outline(profile).T))
    measured = [m for m in measurements.values() if m.status == "measured"]
    # the constructions drawn: a measured method's, adaptive first
    primary = min(measured or list(measurements.values()), key=lambda m: m.method != "adaptive",
                  default=None)  # fmt: skip
    drawing = None
    if len(curves) > (reference in REFERENCE_PROFILES) and primary is not None:
        result = next(r for r in wheel.results if r.method == primary.method)
        labels = construction_labels(
            (primary.profile or {}).get("construction", {}), result.model_dump(), primary.method
        )
        drawing = profile_drawing(curves, labels, reference)
    return WheelSection(wheel, family, limits, margins, drawing)


def _report_key(
    summary: PassSummary,
    wheels: list[PassWheelRead],
    limits: dict,
    amber: dict[str, float],
    train_pass: Pass,
) -> str:
    """sha256 of everything the PDF shows (the job's progress and times excluded); the
    wheels carry their dispositions in force."""
    measurements = sorted(
        (m.id, m.created_at.isoformat()) for w in train_pass.wheels for m in w.measurements
    )
    content = {
        "layout": REPORT_LAYOUT,
        "software": __version__,
        "pass": summary.model_dump(mode="json", exclude={"job"}),
        "wheels": [w.model_dump(mode="json") for w in wheels],
        "measurements": measurements,
        "limits": limits,
        "amber": amber,
    }
    return hashlib.sha256(json.dumps(content, sort_keys=True).encode()).hexdigest()


def _write_atomically(path: Path, data: bytes) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    handle, temporary = tempfile.mkstemp(dir=path.parent, suffix=".part")
    try:
        with os.fdopen(handle, "wb") as stream:
            stream.write(data)
        os.replace(temporary, path)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise


@dataclass(frozen=True, slots=True)
class ReportContent:
    """The stored rows a report shows, and their content key (the PDF's ETag)."""

    key: str
    train_pass: Pass
    only: PassWheel | None
    summary: PassSummary
    wheels: list[PassWheelRead]
    limits: dict[str, dict[str, float]]
    amber: dict[str, float]
    """The fleet's amber band per limit set (fraction of each limit band)."""


def report_content(session: Session, train_pass: Pass, only: PassWheel | None) -> ReportContent:
    """What the report of a pass (or of its wheel `only`) shows, with its content key."""
    summary = pass_summary(session, train_pass)
    wheels = pass_wheels(session, train_pass)
    if only is not None:
        wheels = [w for w in wheels if w.wheel_id == only.wheel_id]
    limits = {f: limits_for(session, train_pass.fleet, f) for f in WHEEL_PROFILES}
    amber = {f: review_thresholds(session, train_pass.fleet, f)[0] for f in WHEEL_PROFILES}
    key = _report_key(summary, wheels, limits, amber, train_pass)
    return ReportContent(key, train_pass, only, summary, wheels, limits, amber)


def report_pdf(content: ReportContent, cache_dir: Path) -> bytes:
    """The PDF of `content`, read from `cache_dir` when the same content was rendered."""
    path = cache_dir / f"{content.key}.pdf"
    try:
        os.utime(path)  # recently used: kept longest by prune_report_cache
        return path.read_bytes()
    except FileNotFoundError:
        pass  # not rendered yet, or pruned meanwhile
    only, summary, wheels, limits = content.only, content.summary, content.wheels, content.limits
    by_wheel = {pw.wheel_id: pw for pw in content.train_pass.wheels}
    sections = [_section(by_wheel[w.wheel_id], w, limits, content.amber) for w in wheels]
    versions = sorted({r.pipeline_version for w in wheels for r in w.results}) or ["–"]
    header = ReportHeader(
        title="Wheel profile report" if only else "Train pass wheel report",
        wheel_report=only is not None,
        generated_at=f"{utc_now():%Y-%m-%d %H:%M} UTC",
        software_version=__version__,
        pipeline_versions=", ".join(versions),
    )
    pdf = render_pdf(summary, sections, limits, content.amber, header)
    _write_atomically(path, pdf)
    prune_report_cache(cache_dir, REPORT_CACHE_FILES)
    return pdf


def prune_report_cache(cache_dir: Path, keep: int) -> int:
    """Remove all but the `keep` newest PDFs and stale half-written files; returns how many
    files went. PDFs are keyed by content, so a removed one is rendered again if asked."""
    now = time.time()
    removed = 0
    for stale, mtime in _modified(cache_dir.glob("*.part")):
        if now - mtime > STALE_PART_S:
            stale.unlink(missing_ok=True)
            removed += 1
    pdfs = sorted(_modified(cache_dir.glob("*.pdf")), key=lambda item: item[1], reverse=True)
    for old, _mtime in pdfs[keep:]:
        old.unlink(missing_ok=True)
        removed += 1
    return removed


def _modified(paths: Iterable[Path]) -> list[tuple[Path, float]]:
    """Each path that still exists with its modification time [s]: a concurrent request may
    rename its half-written file or prune a PDF between the listing and the look."""
    found = []
    for path in paths:
        try:
            found.append((path, path.stat().st_mtime))
        except FileNotFoundError:
            continue
    return found


@dataclass(frozen=True, slots=True)
class RenderedReport:
    """A report file, or None for `data` when the caller's copy (its ETag) is current."""

    data: bytes | None
    filename: str
    media_type: str
    etag: str | None
    """Of a PDF (quoted): its content key."""


MEDIA_TYPES = {"csv": "text/csv", "json": "application/json", "pdf": "application/pdf"}


def render_report(
    session: Session,
    cache_dir: Path,
    train_pass: Pass,
    fmt: str,
    only: PassWheel | None,
    if_none_match: str | None,
) -> RenderedReport:
    """The report of a pass (or of its wheel `only`) as "csv", "json" or "pdf"; a PDF is
    rendered only when `cache_dir` does not hold its content, and not sent (data None) when
    `if_none_match` is its ETag."""
    stem = f"wheelscan-pass-{train_pass.id}" + (f"-wheel-{only.wheel_id}" if only else "")
    content = report_content(session, train_pass, only)
    etag = f'"{content.key[:32]}"'
    if fmt == "csv":
        data: bytes | None = report_csv(content.summary, content.wheels)
    elif fmt == "json":
        report = PassReport.model_validate(
            {"pass": content.summary, "limits": content.limits, "wheels": content.wheels}
        )
        data = report.model_dump_json(by_alias=True).encode()
    else:
        data = None if if_none_match == etag else report_pdf(content, cache_dir)
    return RenderedReport(data, f"{stem}.{fmt}", MEDIA_TYPES[fmt], etag if fmt == "pdf" else None)
