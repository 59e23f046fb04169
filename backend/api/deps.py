"""FastAPI dependencies: settings, session, store, runner, authentication and lookups."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Annotated, Any

from fastapi import Depends, Path, Query, Request
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer
from sqlalchemy import select
from sqlalchemy.orm import Session

from backend.config import Settings
from backend.errors import NotFoundError
from backend.jobs.runner import TaskRunner
from backend.services.auth import authenticate, require_role
from backend.storage.store import BlobStore
from db.models import ROLES, ApiToken, Job, Pass, PassWheel, Site, Wheel
from db.types import MAX_INTEGER


def get_settings_dep(request: Request) -> Settings:
    return request.app.state.settings


def get_session(request: Request) -> Iterator[Session]:
    with request.app.state.session_factory() as session:
        yield session


def get_store(request: Request) -> BlobStore:
    return request.app.state.store


def get_runner(request: Request) -> TaskRunner:
    return request.app.state.runner


RowId = Annotated[int, Path(ge=1, le=MAX_INTEGER, description="id of a stored row")]
Offset = Annotated[int, Query(ge=0, le=MAX_INTEGER, description="rows to skip")]

SettingsDep = Annotated[Settings, Depends(get_settings_dep)]
SessionDep = Annotated[Session, Depends(get_session)]
StoreDep = Annotated[BlobStore, Depends(get_store)]
RunnerDep = Annotated[TaskRunner, Depends(get_runner)]

# Every lookup first checks the role its route declares: 401 and 403 come before 404,
# whatever the order of a route's parameters, so nobody learns which ids exist.
bearer_scheme = HTTPBearer(auto_error=False, description="an API token (wheelscan token create)")


def _role_dependency(role: str) -> Callable[..., ApiToken]:
    def check(
        session: SessionDep,
        credentials: Annotated[HTTPAuthorizationCredentials | None, Depends(bearer_scheme)],
    ) -> ApiToken:
        token = authenticate(session, credentials.credentials if credentials else None)
        require_role(token, role)
        return token

    check.__name__ = f"require_{role}"
    return check


ViewerDep = Annotated[ApiToken, Depends(_role_dependency("viewer"))]
OperatorDep = Annotated[ApiToken, Depends(_role_dependency("operator"))]
AdminDep = Annotated[ApiToken, Depends(_role_dependency("admin"))]

_ROUTE_ROLES: dict[int, str] = {}


def _declared_role(dependant: Any) -> str:
    """The highest role any `require_<role>` dependency of `dependant` asks for."""
    found = ROLES[0]
    for sub in dependant.dependencies:
        name = getattr(sub.call, "__name__", "").removeprefix("require_")
        for role in (name, _declared_role(sub)):
            if role in ROLES and ROLES.index(role) > ROLES.index(found):
                found = role
    return found


def require_route_role(
    request: Request,
    session: SessionDep,
    credentials: Annotated[HTTPAuthorizationCredentials | None, Depends(bearer_scheme)],
) -> ApiToken:
    """Authenticate with the role the matched route declares, before any lookup runs."""
    route = request.scope.get("route")
    role = _ROUTE_ROLES.get(id(route))
    if role is None:
        role = _declared_role(route.dependant) if hasattr(route, "dependant") else ROLES[0]
        _ROUTE_ROLES[id(route)] = role
    token = authenticate(session, credentials.credentials if credentials else None)
    require_role(token, role)
    return token


CallerDep = Annotated[ApiToken, Depends(require_route_role)]


def get_pass_or_404(session: SessionDep, pass_id: RowId, _caller: CallerDep) -> Pass:
    train_pass = session.get(Pass, pass_id)
    if train_pass is None:
        raise NotFoundError(f"pass {pass_id} not found")
    return train_pass


def get_job_or_404(session: SessionDep, job_id: RowId, _caller: CallerDep) -> Job:
    job = session.get(Job, job_id)
    if job is None:
        raise NotFoundError(f"job {job_id} not found")
    return job


def get_wheel_or_404(session: SessionDep, wheel_id: RowId, _caller: CallerDep) -> Wheel:
    wheel = session.get(Wheel, wheel_id)
    if wheel is None:
        raise NotFoundError(f"wheel {wheel_id} not found")
    return wheel


def get_site_or_404(session: SessionDep, site_name: str, _caller: CallerDep) -> Site:
    site = session.scalar(select(Site).where(Site.name == site_name))
    if site is None:
        raise NotFoundError(f"site {site_name!r} not found; create it with POST /api/sites")
    return site


def get_pass_wheel_or_404(
    session: SessionDep, pass_id: RowId, wheel_id: RowId, _viewer: ViewerDep
) -> PassWheel:
    pass_wheel = session.scalar(
        select(PassWheel).where(PassWheel.pass_id == pass_id, PassWheel.wheel_id == wheel_id)
    )
    if pass_wheel is None:
        raise NotFoundError(f"wheel {wheel_id} is not in pass {pass_id}")
    return pass_wheel


PassDep = Annotated[Pass, Depends(get_pass_or_404)]
JobDep = Annotated[Job, Depends(get_job_or_404)]
WheelDep = Annotated[Wheel, Depends(get_wheel_or_404)]
SiteDep = Annotated[Site, Depends(get_site_or_404)]
PassWheelDep = Annotated[PassWheel, Depends(get_pass_wheel_or_404)]
