"""Sites and their versioned calibrations (a new version per change; never edited in place)."""

from __future__ import annotations

import hashlib
import json
from typing import Any

from sqlalchemy import func, select
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session

from backend.api.schemas import SiteRead
from backend.errors import ConflictError, InvalidInputError, NotFoundError
from backend.services.auth import record_audit
from db.models import ApiToken, Calibration, Site
from pipeline.calibration.model import (
    StationCalibration,
    calibration_to_document,
    parse_calibration,
)
from pipeline.errors import CalibrationError


def canonical_sha256(document: dict[str, Any]) -> str:
    """sha256 of a JSON document in canonical form (sorted keys, no spaces)."""
    text = json.dumps(document, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def validate_calibration_document(document: object) -> StationCalibration:
    """Parse a wheelscan-calibration/1 object; InvalidInputError says what to fix."""
    try:
        return parse_calibration(document)
    except CalibrationError as exc:
        raise InvalidInputError(f"calibration: {exc}") from None


def get_or_create_site(session: Session, name: str) -> Site:
    """The site called `name`, created when new (safe against a concurrent creator)."""
    site = session.scalar(select(Site).where(Site.name == name))
    if site is not None:
        return site
    try:
        with session.begin_nested():
            site = Site(name=name)
            session.add(site)
    except IntegrityError:
        site = session.scalars(select(Site).where(Site.name == name)).one()
    return site


def current_calibration(session: Session, site: Site) -> Calibration | None:
    """The newest calibration an admin registered for `site`, or None."""
    return session.scalar(
        select(Calibration)
        .where(Calibration.site_id == site.id, Calibration.registered.is_(True))
        .order_by(Calibration.version.desc())
        .limit(1)
    )


def add_calibration_version(
    session: Session,
    site: Site,
    calibration: StationCalibration,
    *,
    registered: bool,
    note: str | None = None,
) -> Calibration:
    """Store `calibration` for `site` as a new version, or reuse an identical one.

    From an archive (`registered=False`): any stored version with the same document is
    reused. From an admin (`registered=True`): a no-op when the current version is the same
    document, otherwise a new version that becomes the current one (earlier passes keep theirs).
    """
    document = calibration_to_document(calibration)
    sha256 = canonical_sha256(document)
    if registered:
        current = current_calibration(session, site)
        if current is not None and current.sha256 == sha256:
            return current
    else:
        same = session.scalar(
            select(Calibration)
            .where(Calibration.site_id == site.id, Calibration.sha256 == sha256)
            .order_by(Calibration.version.desc())
            .limit(1)
        )
        if same is not None:
            return same
    last = session.scalar(
        select(func.max(Calibration.version)).where(Calibration.site_id == site.id)
    )
    row = Calibration(
        site_id=site.id,
        version=(last or 0) + 1,
        sha256=sha256,
        document=document,
        note=note,
        registered=registered,
    )
    session.add(row)
    session.flush()
    return row


def site_read(session: Session, site: Site) -> SiteRead:
    """A site with its current calibration version."""
    current = current_calibration(session, site)
    return SiteRead(
        id=site.id,
        name=site.name,
        created_at=site.created_at,
        current_calibration_version=current.version if current else None,
        rail_profile=site.rail_profile,
        rail_inclination=site.rail_inclination,
        gauge_mm=site.gauge_mm,
    )


def all_sites(session: Session) -> list[SiteRead]:
    """Every site by name, with its current calibration version."""
    return [site_read(session, site) for site in session.scalars(select(Site).order_by(Site.name))]


def create_site(session: Session, admin: ApiToken, name: str) -> SiteRead:
    """Register a site called `name` (audited, committed); ConflictError when it exists."""
    if session.scalar(select(Site).where(Site.name == name)) is not None:
        raise ConflictError(f"site {name!r} exists already")
    site = Site(name=name)
    session.add(site)
    session.flush()
    record_audit(session, admin, "site.create", "site", site.id, {"name": site.name})
    session.commit()
    return site_read(session, site)


def site_calibrations(session: Session, site: Site) -> list[Calibration]:
    """Every calibration version of `site`, newest first."""
    return list(
        session.scalars(
            select(Calibration)
            .where(Calibration.site_id == site.id)
            .order_by(Calibration.version.desc())
        )
    )


def register_calibration(
    session: Session, admin: ApiToken, site: Site, document: object, note: str | None
) -> Calibration:
    """Validate a wheelscan-calibration/1 document and make it the site's current version
    (audited, committed)."""
    station = validate_calibration_document(document)
    row = add_calibration_version(session, site, station, registered=True, note=note)
    record_audit(
        session,
        admin,
        "calibration.register",
        "calibration",
        row.id,
        {"site": site.name, "version": row.version, "sha256": row.sha256},
    )
    session.commit()
    return row


def calibration_or_404(session: Session, calibration_id: int) -> Calibration:
    """One calibration version by id; NotFoundError when there is none."""
    row = session.get(Calibration, calibration_id)
    if row is None:
        raise NotFoundError(f"calibration {calibration_id} not found")
    return row


def set_site_rails(
    session: Session,
    admin: ApiToken,
    site: Site,
    rail_profile: str,
    inclination: str,
    gauge_mm: float,
) -> SiteRead:
    """Set the rails of `site` (audited, committed): axles measured from now on get their
    conicity on these rails; results stored before keep theirs."""
    before = {"rail_profile": site.rail_profile, "rail_inclination": site.rail_inclination,
              "gauge_mm": site.gauge_mm}  # fmt: skip
    site.rail_profile, site.rail_inclination, site.gauge_mm = rail_profile, inclination, gauge_mm
    after = {"rail_profile": rail_profile, "rail_inclination": inclination, "gauge_mm": gauge_mm}
    record_audit(session, admin, "site.rails", "site", site.id, {"before": before, "after": after})
    session.commit()
    return site_read(session, site)
