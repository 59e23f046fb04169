"""Sites and their calibration versions (list: viewer; create/register: admin)."""

from __future__ import annotations

from fastapi import APIRouter, status
from sqlalchemy import select

from backend.api.deps import AdminDep, RowId, SessionDep, SiteDep, ViewerDep
from backend.api.schemas import CalibrationCreate, CalibrationRead, SiteCreate, SiteRead
from backend.errors import ERROR_RESPONSES, ConflictError, NotFoundError
from backend.services.auth import record_audit
from backend.services.sites import (
    add_calibration_version,
    current_calibration,
    validate_calibration_document,
)
from db.models import Calibration, Site

router = APIRouter(prefix="/api", tags=["sites and calibrations"], responses=ERROR_RESPONSES)


def _site_read(session: SessionDep, site: Site) -> SiteRead:
    current = current_calibration(session, site)
    return SiteRead(
        id=site.id,
        name=site.name,
        created_at=site.created_at,
        current_calibration_version=current.version if current else None,
    )


@router.get("/sites")
def list_sites(session: SessionDep, _viewer: ViewerDep) -> list[SiteRead]:
    """Every site with its current calibration version."""
    return [_site_read(session, site) for site in session.scalars(select(Site).order_by(Site.name))]


@router.post("/sites", status_code=status.HTTP_201_CREATED)
def post_site(body: SiteCreate, session: SessionDep, admin: AdminDep) -> SiteRead:
    """Register a site (a name that manifests and streams refer to)."""
    if session.scalar(select(Site).where(Site.name == body.name)) is not None:
        raise ConflictError(f"site {body.name!r} exists already")
    site = Site(name=body.name)
    session.add(site)
    session.flush()
    record_audit(session, admin, "site.create", "site", site.id, {"name": site.name})
    session.commit()
    return _site_read(session, site)


@router.get("/sites/{site_name}/calibrations")
def list_calibrations(
    site: SiteDep, session: SessionDep, _viewer: ViewerDep
) -> list[CalibrationRead]:
    """Every calibration version of a site, newest first (registered or from archives)."""
    rows = session.scalars(
        select(Calibration)
        .where(Calibration.site_id == site.id)
        .order_by(Calibration.version.desc())
    )
    return [CalibrationRead.model_validate(row) for row in rows]


@router.post("/sites/{site_name}/calibrations", status_code=status.HTTP_201_CREATED)
def post_calibration(
    body: CalibrationCreate, site: SiteDep, session: SessionDep, admin: AdminDep
) -> CalibrationRead:
    """Register a new calibration version; it becomes the site's current one."""
    station = validate_calibration_document(body.document)
    row = add_calibration_version(session, site, station, registered=True, note=body.note)
    record_audit(
        session,
        admin,
        "calibration.register",
        "calibration",
        row.id,
        {"site": site.name, "version": row.version, "sha256": row.sha256},
    )
    session.commit()
    return CalibrationRead.model_validate(row)


@router.get("/calibrations/{calibration_id}")
def get_calibration(
    calibration_id: RowId, session: SessionDep, _viewer: ViewerDep
) -> CalibrationRead:
    """One calibration version, as measured passes used it."""
    row = session.get(Calibration, calibration_id)
    if row is None:
        raise NotFoundError(f"calibration {calibration_id} not found")
    return CalibrationRead.model_validate(row)
