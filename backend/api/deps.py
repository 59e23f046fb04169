"""FastAPI dependencies: settings, session, store, runner, authentication and lookups."""

from __future__ import annotations

import inspect
from collections.abc import Callable, Iterator, Sequence
from typing import Annotated, Any, TypeVar, get_args, get_origin, get_type_hints

from fastapi import Depends, Path, Query, Request, params
from fastapi.routing import APIRoute
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

T = TypeVar("T")


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


def _dependencies(call: Callable[..., Any]) -> list[params.Depends]:
    """The `Depends(...)` markers of a function's parameters (annotated or as defaults)."""
    if not inspect.isfunction(call):
        return []  # a security scheme or a class: it declares no role
    found: list[params.Depends] = []
    hints = get_type_hints(call, include_extras=True)
    for name, parameter in inspect.signature(call).parameters.items():
        hint = hints.get(name)
        markers = list(get_args(hint)[1:]) if get_origin(hint) is Annotated else []
        found.extend(m for m in [*markers, parameter.default] if isinstance(m, params.Depends))
    return found


def _declared_role(dependencies: Sequence[params.Depends]) -> str:
    """The highest role any `require_<role>` among `dependencies` (or theirs) asks for."""
    found = ROLES[0]
    for depends in dependencies:
        call = depends.dependency
        name = getattr(call, "__name__", "").removeprefix("require_")
        inner = _declared_role(_dependencies(call)) if call is not None else ROLES[0]
        for role in (name, inner):
            if role in ROLES and ROLES.index(role) > ROLES.index(found):
                found = role
    return found


def _route_role(route: object) -> str:
    """The role a matched route declares, through its endpoint's and its decorator's
    dependencies (cached per route)."""
    role = _ROUTE_ROLES.get(id(route))
    if role is None:
        if isinstance(route, APIRoute):
            role = _declared_role([*route.dependencies, *_dependencies(route.endpoint)])
        else:
            role = ROLES[0]
        _ROUTE_ROLES[id(route)] = role
    return role


def require_route_role(
    request: Request,
    session: SessionDep,
    credentials: Annotated[HTTPAuthorizationCredentials | None, Depends(bearer_scheme)],
) -> ApiToken:
    """Authenticate with the role the matched route declares, before any lookup runs."""
    role = _route_role(request.scope.get("route"))
    token = authenticate(session, credentials.credentials if credentials else None)
    require_role(token, role)
    return token


CallerDep = Annotated[ApiToken, Depends(require_route_role)]


def _found(row: T | None, missing: str) -> T:
    """`row`, or NotFoundError(`missing`) where the lookup found none."""
    if row is None:
        raise NotFoundError(missing)
    return row


def get_pass_or_404(session: SessionDep, pass_id: RowId, _caller: CallerDep) -> Pass:
    return _found(session.get(Pass, pass_id), f"pass {pass_id} not found")


def get_job_or_404(session: SessionDep, job_id: RowId, _caller: CallerDep) -> Job:
    return _found(session.get(Job, job_id), f"job {job_id} not found")


def get_wheel_or_404(session: SessionDep, wheel_id: RowId, _caller: CallerDep) -> Wheel:
    return _found(session.get(Wheel, wheel_id), f"wheel {wheel_id} not found")


def get_site_or_404(session: SessionDep, site_name: str, _caller: CallerDep) -> Site:
    return _found(
        session.scalar(select(Site).where(Site.name == site_name)),
        f"site {site_name!r} not found; create it with POST /api/sites",
    )


def get_pass_wheel_or_404(
    session: SessionDep, pass_id: RowId, wheel_id: RowId, _viewer: ViewerDep
) -> PassWheel:
    return _found(
        session.scalar(
            select(PassWheel).where(PassWheel.pass_id == pass_id, PassWheel.wheel_id == wheel_id)
        ),
        f"wheel {wheel_id} is not in pass {pass_id}",
    )


PassDep = Annotated[Pass, Depends(get_pass_or_404)]
JobDep = Annotated[Job, Depends(get_job_or_404)]
WheelDep = Annotated[Wheel, Depends(get_wheel_or_404)]
SiteDep = Annotated[Site, Depends(get_site_or_404)]
PassWheelDep = Annotated[PassWheel, Depends(get_pass_wheel_or_404)]
