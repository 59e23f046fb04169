"""Sites and their versioned calibrations (a new version per change; never edited in place)."""

from __future__ import annotations

import hashlib
import json
from typing import Any

from sqlalchemy import func, select
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session

from backend.errors import InvalidInputError
from db.models import Calibration, Site
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
