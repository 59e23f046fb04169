"""The depot's review: wheels ranked by their margin to the nearest limit, the operators'
dispositions, and the flag where the two extraction methods disagree.

The ranking reads the margins stored with each measurement (`measurement_margin`), so the
worst-wheels view is one indexed query however many passes there are. Reports call
`wheel_reviews` for the margins and dispositions of a pass's wheels.
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import UTC
from typing import cast

from sqlalchemy import ColumnElement, Select, and_, exists, func, or_, select
from sqlalchemy.orm import Session

from backend.api.schemas import (
    Disagreement,
    DispositionCreate,
    DispositionRead,
    MarginRead,
    MethodResult,
    Page,
    Side,
    WorstWheelRead,
)
from backend.errors import InvalidInputError
from backend.services.auth import record_audit
from backend.services.limits import (
    REFERENCE_PROFILE_FAMILY,
    WHEEL_PROFILES,
    profile_family,
    review_thresholds,
)
from backend.services.margins import PARAMETER_KEYS, PARAMETERS
from backend.services.results import measurement_margins, store_margins
from db.models import (
    ApiToken,
    Disposition,
    Measurement,
    MeasurementMargin,
    Pass,
    PassWheel,
    Site,
    Wheel,
)

PRIMARY_METHOD = "adaptive"
"""Margins, levels and the ranking come from the product's method (Steger is the baseline)."""
UNLIMITED_VALUES = ("tread_hollow_mm", "flange_angle_deg", "rim_width_mm", "equivalent_conicity")
"""Values each worst-wheels row carries beside its margin (the first three have no limit to
rank by)."""
NEEDS_COMMENT = {"false_alarm": "a false alarm needs its reason", "comment": "a comment is empty"}
DISPOSITION_WORDS = {
    "re_profile": "re-profile",
    "monitor": "monitor",
    "false_alarm": "false alarm",
    "measurement_doubtful": "measurement doubtful",
    "comment": "comment",
}
"""A disposition's kind as the web app and the reports write it."""


@dataclass(frozen=True, slots=True)
class WorstWheelFilter:
    """What the worst-wheels view shows; text filters match anywhere, case-insensitive."""

    site: str | None = None
    fleet: str | None = None
    vehicle: str | None = None
    parameter: str | None = None
    pass_id: int | None = None
    latest_only: bool = True
    open_only: bool = False
    unchecked_only: bool = False
    """Only measurements with a flange limit left unchecked, their Sd (LM), Sd 10 (EN) or qR
    not measured: their flange must be gauged by hand."""


@dataclass(frozen=True, slots=True)
class WheelReview:
    """The review state of one wheel of a pass (for pages and reports)."""

    level: str
    margins: list[MarginRead]
    disposition: DispositionRead | None


def _filtered(query: Select, where: WorstWheelFilter, newest: list[int] | None) -> Select:
    query = query.where(Measurement.method == PRIMARY_METHOD)
    if where.parameter is None:
        query = query.where(MeasurementMargin.nearest.is_(True))
    elif where.parameter in PARAMETER_KEYS:
        query = query.where(MeasurementMargin.parameter == where.parameter)
    else:
        raise InvalidInputError(
            f"parameter must be one of {', '.join(PARAMETER_KEYS)}, got {where.parameter!r}"
        )
    if where.site:
        query = query.where(Site.name.icontains(where.site, autoescape=True))
    if where.fleet:
        query = query.where(Pass.fleet.icontains(where.fleet, autoescape=True))
    if where.vehicle:
        query = query.where(Wheel.vehicle_id.icontains(where.vehicle, autoescape=True))
    if where.pass_id is not None:
        query = query.where(PassWheel.pass_id == where.pass_id)
    if newest is not None:
        query = query.where(Measurement.pass_wheel_id.in_(newest))
    if where.open_only:
        query = query.where(~exists().where(Disposition.pass_wheel_id == PassWheel.id))
    if where.unchecked_only:
        query = query.where(_flange_limit_unchecked())
    return query


FLANGE_VALUES = ("flange_thickness_mm", "flange_thickness_10_mm", "qr_mm")
"""The flange values a measured wheel can lack (`FlangeParameters.reason` names them)."""


def _flange_limit_unchecked() -> ColumnElement[bool]:
    """SQL: the measurement lacks a flange value its family's limits check (Sd for LM, Sd 10
    for EN, qR for both; `margins.PARAMETERS`), the family read from its reference profile
    as `limits.profile_family` reads it."""
    lm_names = [name for name, family in REFERENCE_PROFILE_FAMILY.items() if family == "LM"]
    is_lm = func.upper(func.coalesce(Measurement.reference_profile, "")).in_(lm_names)
    family = {"LM": is_lm, "EN": ~is_lm}
    missing = []
    for parameter in PARAMETERS:
        if parameter.key in FLANGE_VALUES:
            checked = or_(*(family[f] for f in parameter.families))
            missing.append(and_(checked, getattr(Measurement, parameter.key).is_(None)))
    return and_(Measurement.reason.is_not(None), or_(*missing))


def _joined(query: Select, where: WorstWheelFilter | None = None) -> Select:
    """The margins joined up to the site; with `where`, only the joins its filters need
    (the count: PostgreSQL counted 64,000 rows in 198 ms through all five joins)."""
    query = query.join(Measurement, MeasurementMargin.measurement_id == Measurement.id)
    needs_pass = where is None or bool(where.site or where.fleet or where.pass_id)
    if where is None or needs_pass or where.vehicle or where.open_only:
        query = query.join(PassWheel, Measurement.pass_wheel_id == PassWheel.id)
    if where is None or where.vehicle:
        query = query.join(Wheel, PassWheel.wheel_id == Wheel.id)
    if needs_pass:
        query = query.join(Pass, PassWheel.pass_id == Pass.id)
    if where is None or where.site:
        query = query.join(Site, Pass.site_id == Site.id)
    return query


def _newest_pass_wheels(session: Session) -> list[int]:
    """The pass wheel of each wheel's newest measured pass.

    Found first and given to the ranking as ids: planners then start from these few rows
    (one per wheel) instead of walking every pass's margins (SQLite took 0.7 s for
    1,000 passes × 64 wheels the other way, 0.09 s this way). SQLite binds at most 32,766
    values, so this holds for fleets of up to that many wheels.
    """
    newest = (
        select(PassWheel.wheel_id, func.max(Pass.started_at).label("started_at"))
        .join(Pass, PassWheel.pass_id == Pass.id)
        .where(PassWheel.state == "measured")
        .group_by(PassWheel.wheel_id)
        .subquery("newest")
    )
    return list(
        session.scalars(
            select(PassWheel.id)
            .join(Pass, PassWheel.pass_id == Pass.id)
            .join(
                newest,
                (newest.c.wheel_id == PassWheel.wheel_id)
                & (newest.c.started_at == Pass.started_at),
            )
        )
    )


def worst_wheels(
    session: Session, where: WorstWheelFilter, offset: int, limit: int
) -> Page[WorstWheelRead]:
    """Wheels by their margin to the nearest limit (as a fraction of the band), smallest
    first: alarms, then amber, then the rest; by default each wheel's newest pass only."""
    newest = _newest_pass_wheels(session) if where.latest_only and where.pass_id is None else None
    total = session.scalar(
        _filtered(_joined(select(func.count(MeasurementMargin.id)), where), where, newest)
    )
    rows = session.execute(
        _filtered(
            _joined(
                select(
                    MeasurementMargin,
                    PassWheel.id,
                    Wheel,
                    Pass,
                    Site.name,
                    Measurement.reference_profile,
                    Measurement.reason,
                    *(getattr(Measurement, name) for name in UNLIMITED_VALUES),
                )
            ),
            where,
            newest,
        )
        .order_by(MeasurementMargin.margin_fraction, MeasurementMargin.id)
        .offset(offset)
        .limit(limit)
    ).all()
    dispositions = current_dispositions(session, [row[1] for row in rows])
    items = [
        WorstWheelRead(
            pass_id=train_pass.id,
            started_at=train_pass.started_at,
            site=site,
            fleet=train_pass.fleet,
            wheel_id=wheel.id,
            vehicle_id=wheel.vehicle_id,
            axle=wheel.axle,
            side=cast(Side, wheel.side),
            wheel_profile=profile_family(reference),
            margin=MarginRead.model_validate(margin),
            disposition=dispositions.get(pass_wheel_id),
            values_not_measured=missing,
            **dict(zip(UNLIMITED_VALUES, values, strict=True)),
        )
        for margin, pass_wheel_id, wheel, train_pass, site, reference, missing, *values in rows
    ]
    return Page[WorstWheelRead](items=items, total=total or 0, offset=offset, limit=limit)


def current_dispositions(session: Session, pass_wheel_ids: list[int]) -> dict[int, DispositionRead]:
    """The disposition in force (the newest) of each listed pass wheel that has one."""
    found: dict[int, DispositionRead] = {}
    if not pass_wheel_ids:
        return found
    for row in session.scalars(
        select(Disposition)
        .where(Disposition.pass_wheel_id.in_(pass_wheel_ids))
        .order_by(Disposition.created_at, Disposition.id)
    ):
        found[row.pass_wheel_id] = DispositionRead.model_validate(row)
    return found


def disposition_text(disposition: DispositionRead | None) -> str:
    """A disposition in words, who recorded it and when (UTC): "false alarm: wet rail — by
    J. Doe, 2026-12-01 19:05 UTC"; "open" where there is none."""
    if disposition is None:
        return "open"
    words = DISPOSITION_WORDS[disposition.kind]
    what = f"{words}: {disposition.comment}" if disposition.comment else words
    at = disposition.created_at.astimezone(UTC)
    return f"{what} — by {disposition.actor}, {at:%Y-%m-%d %H:%M} UTC"


def dispositions_of(session: Session, pass_wheel: PassWheel) -> list[DispositionRead]:
    """Every disposition of a wheel of a pass, newest first."""
    rows = session.scalars(
        select(Disposition)
        .where(Disposition.pass_wheel_id == pass_wheel.id)
        .order_by(Disposition.created_at.desc(), Disposition.id.desc())
    )
    return [DispositionRead.model_validate(row) for row in rows]


def add_disposition(
    session: Session, pass_wheel: PassWheel, body: DispositionCreate, token: ApiToken
) -> DispositionRead:
    """Record an operator's decision on a wheel of a pass, audited, and commit."""
    comment = (body.comment or "").strip() or None
    if comment is None and body.kind in NEEDS_COMMENT:
        raise InvalidInputError(f"comment: {NEEDS_COMMENT[body.kind]}; say why in a few words")
    event = record_audit(
        session,
        token,
        "disposition.create",
        "pass_wheel",
        f"{pass_wheel.pass_id}/{pass_wheel.wheel_id}",
        {"kind": body.kind, "comment": comment},
    )
    row = Disposition(
        pass_wheel_id=pass_wheel.id,
        kind=body.kind,
        comment=comment,
        actor=event.actor,
        token_id=event.token_id,
        created_at=event.at,
    )
    session.add(row)
    session.commit()
    return DispositionRead.model_validate(row)


def wheel_reviews(session: Session, pass_wheels: list[PassWheel]) -> dict[int, WheelReview]:
    """Level, margins (adaptive) and disposition in force of each pass wheel, by its id."""
    dispositions = current_dispositions(session, [pw.id for pw in pass_wheels])
    reviews = {}
    for pass_wheel in pass_wheels:
        primary = next((m for m in pass_wheel.measurements if m.method == PRIMARY_METHOD), None)
        margins = [MarginRead.model_validate(m) for m in primary.margins] if primary else []
        levels = {m.level for m in margins}
        level = next((lv for lv in ("alarm", "near") if lv in levels), "ok" if margins else "none")
        reviews[pass_wheel.id] = WheelReview(level, margins, dispositions.get(pass_wheel.id))
    return reviews


def disagreement_thresholds(session: Session, fleet: str) -> dict[str, float]:
    """The fleet's method-disagreement threshold per limit family [mm]."""
    return {family: review_thresholds(session, fleet, family)[1] for family in WHEEL_PROFILES}


def method_disagreements(
    results: list[MethodResult], thresholds_mm: dict[str, float]
) -> list[Disagreement]:
    """The parameters where adaptive and Steger differ by more than the threshold of the
    wheel's limit family (`disagreement_thresholds`)."""
    by_method = {r.method: r for r in results if r.status == "measured"}
    adaptive, steger = by_method.get(PRIMARY_METHOD), by_method.get("steger")
    if adaptive is None or steger is None:
        return []
    threshold_mm = thresholds_mm[profile_family(adaptive.reference_profile)]
    flagged = []
    for key in PARAMETER_KEYS:
        a, s = getattr(adaptive, key), getattr(steger, key)
        if a is not None and s is not None and abs(a - s) > threshold_mm:
            flagged.append(
                Disagreement(parameter=key, difference_mm=a - s, threshold_mm=threshold_mm)
            )
    return flagged


def backfill_margins(session: Session) -> int:
    """Margins for measured results stored before margins were kept; returns how many."""
    missing = session.scalars(
        select(Measurement)
        .where(
            Measurement.status == "measured",
            ~exists().where(MeasurementMargin.measurement_id == Measurement.id),
        )
        .order_by(Measurement.id)
    ).all()
    for row in missing:
        # margins only: the stored alarms stay those of the limits they were measured under
        store_margins(row, measurement_margins(row, row.pass_wheel.train_pass.fleet, session))
    session.commit()
    return len(missing)
