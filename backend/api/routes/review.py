"""The depot's review: worst wheels by margin (viewer), dispositions (viewer reads,
operator writes), and the checked parameters."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Query, status

from backend.api.deps import Offset, OperatorDep, PassWheelDep, SessionDep, ViewerDep
from backend.api.schemas import (
    DispositionCreate,
    DispositionRead,
    Page,
    ParameterRead,
    WorstWheelRead,
)
from backend.errors import ERROR_RESPONSES
from backend.services.margins import PARAMETERS
from backend.services.review import (
    WorstWheelFilter,
    add_disposition,
    dispositions_of,
    worst_wheels,
)
from db.types import MAX_INTEGER

router = APIRouter(prefix="/api", tags=["review"], responses=ERROR_RESPONSES)


@router.get("/parameters")
def get_parameters(_viewer: ViewerDep) -> list[ParameterRead]:
    """The checked wheel parameters, in display order, with labels and units."""
    return [ParameterRead(key=p.key, label=p.label, title=p.title, unit=p.unit) for p in PARAMETERS]


@router.get("/review/worst-wheels")
def get_worst_wheels(
    session: SessionDep,
    _viewer: ViewerDep,
    site: str | None = None,
    fleet: str | None = None,
    vehicle: str | None = None,
    parameter: Annotated[str | None, Query(description="a parameter key; default: nearest")] = None,
    pass_id: Annotated[int | None, Query(ge=1, le=MAX_INTEGER, description="one pass only")] = None,
    latest_only: Annotated[bool, Query(description="each wheel's newest pass only")] = True,
    open_only: Annotated[bool, Query(description="only wheels without a disposition")] = False,
    unchecked_only: Annotated[
        bool,
        Query(
            description="only wheels with a flange limit left unchecked: Sd (LM), Sd 10 (EN) "
            "or qR not measured (gauge them by hand)"
        ),
    ] = False,
    offset: Offset = 0,
    limit: Annotated[int, Query(ge=1, le=500)] = 50,
) -> Page[WorstWheelRead]:
    """Wheels by margin to their nearest limit (fraction of the band), smallest first."""
    where = WorstWheelFilter(
        site, fleet, vehicle, parameter, pass_id, latest_only, open_only, unchecked_only
    )
    return worst_wheels(session, where, offset, limit)


@router.get("/passes/{pass_id}/wheels/{wheel_id}/dispositions")
def get_dispositions(
    pass_wheel: PassWheelDep, session: SessionDep, _viewer: ViewerDep
) -> list[DispositionRead]:
    """Every disposition of the wheel in this pass, newest (the one in force) first."""
    return dispositions_of(session, pass_wheel)


@router.post(
    "/passes/{pass_id}/wheels/{wheel_id}/dispositions", status_code=status.HTTP_201_CREATED
)
def post_disposition(
    operator: OperatorDep, body: DispositionCreate, pass_wheel: PassWheelDep, session: SessionDep
) -> DispositionRead:
    """Record a decision on the wheel (re-profile, monitor, false alarm with its reason,
    measurement doubtful, or a comment); audited with who and when."""
    return add_disposition(session, pass_wheel, body, operator)
