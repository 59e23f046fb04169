"""Sites and their calibration versions (list: viewer; create/register: admin)."""

from __future__ import annotations

from fastapi import APIRouter, status

from backend.api.deps import AdminDep, RowId, SessionDep, SiteDep, ViewerDep
from backend.api.schemas import (
    CalibrationCreate,
    CalibrationRead,
    SiteCreate,
    SiteRails,
    SiteRead,
)
from backend.errors import ERROR_RESPONSES
from backend.services.sites import (
    all_sites,
    calibration_or_404,
    create_site,
    register_calibration,
    set_site_rails,
    site_calibrations,
)

router = APIRouter(prefix="/api", tags=["sites and calibrations"], responses=ERROR_RESPONSES)


@router.get("/sites")
def list_sites(session: SessionDep, _viewer: ViewerDep) -> list[SiteRead]:
    """Every site with its current calibration version."""
    return all_sites(session)


@router.post("/sites", status_code=status.HTTP_201_CREATED)
def post_site(body: SiteCreate, session: SessionDep, admin: AdminDep) -> SiteRead:
    """Register a site (a name that manifests and streams refer to)."""
    return create_site(session, admin, body.name)


@router.put("/sites/{site_name}/rails")
def put_site_rails(
    body: SiteRails, site: SiteDep, session: SessionDep, admin: AdminDep
) -> SiteRead:
    """Set the rails (60E1 or 54E1, 1:40 or 1:20, gauge) the site's axle conicity uses."""
    return set_site_rails(
        session, admin, site, body.rail_profile, body.rail_inclination, body.gauge_mm
    )


@router.get("/sites/{site_name}/calibrations")
def list_calibrations(
    site: SiteDep, session: SessionDep, _viewer: ViewerDep
) -> list[CalibrationRead]:
    """Every calibration version of a site, newest first (registered or from archives)."""
    return [CalibrationRead.model_validate(row) for row in site_calibrations(session, site)]


@router.post("/sites/{site_name}/calibrations", status_code=status.HTTP_201_CREATED)
def post_calibration(
    body: CalibrationCreate, site: SiteDep, session: SessionDep, admin: AdminDep
) -> CalibrationRead:
    """Register a new calibration version; it becomes the site's current one."""
    row = register_calibration(session, admin, site, body.document, body.note)
    return CalibrationRead.model_validate(row)


@router.get("/calibrations/{calibration_id}")
def get_calibration(
    calibration_id: RowId, session: SessionDep, _viewer: ViewerDep
) -> CalibrationRead:
    """One calibration version, as measured passes used it."""
    return CalibrationRead.model_validate(calibration_or_404(session, calibration_id))
