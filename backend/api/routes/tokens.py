"""API tokens (admin): create, list, revoke."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Query, status
from sqlalchemy import select

from backend.api.deps import AdminDep, Offset, RowId, SessionDep, ViewerDep
from backend.api.schemas import AuditRead, Me, TokenCreate, TokenCreated, TokenRead
from backend.errors import ERROR_RESPONSES, NotFoundError
from backend.services.auth import create_token, record_audit
from db.models import ApiToken, AuditEvent
from db.types import utc_now

router = APIRouter(prefix="/api", tags=["tokens"], responses=ERROR_RESPONSES)


@router.get("/me")
def get_me(viewer: ViewerDep) -> Me:
    """The role and name of the presented token (any role)."""
    return Me.model_validate({"role": viewer.role, "name": viewer.name, "prefix": viewer.prefix})


@router.get("/tokens")
def list_tokens(session: SessionDep, _admin: AdminDep) -> list[TokenRead]:
    """Every token (never the secret itself), newest first."""
    rows = session.scalars(select(ApiToken).order_by(ApiToken.id.desc()))
    return [TokenRead.model_validate(row) for row in rows]


@router.post("/tokens", status_code=status.HTTP_201_CREATED)
def post_token(body: TokenCreate, session: SessionDep, admin: AdminDep) -> TokenCreated:
    """Create a token; the response is the only time its secret is shown."""
    row, plaintext = create_token(
        session, role=body.role, name=body.name, expires_at=body.expires_at
    )
    record_audit(session, admin, "token.create", "token", row.id, {"role": row.role})
    session.commit()
    return TokenCreated.model_validate(
        {**TokenRead.model_validate(row).model_dump(), "token": plaintext}
    )


@router.delete("/tokens/{token_id}")
def revoke_token(token_id: RowId, session: SessionDep, admin: AdminDep) -> TokenRead:
    """Revoke a token at once (idempotent)."""
    row = session.get(ApiToken, token_id)
    if row is None:
        raise NotFoundError(f"token {token_id} not found")
    if row.revoked_at is None:
        row.revoked_at = utc_now()
        record_audit(session, admin, "token.revoke", "token", row.id)
        session.commit()
    return TokenRead.model_validate(row)


@router.get("/audit")
def list_audit(
    session: SessionDep,
    _admin: AdminDep,
    offset: Offset = 0,
    limit: Annotated[int, Query(ge=1, le=1000)] = 100,
) -> list[AuditRead]:
    """The audit trail, newest first: who wrote what, when."""
    rows = session.scalars(
        select(AuditEvent).order_by(AuditEvent.id.desc()).offset(offset).limit(limit)
    )
    return [AuditRead.model_validate(row) for row in rows]
