"""API tokens (admin): create, list, revoke."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Query, status

from backend.api.deps import AdminDep, Offset, RowId, SessionDep, ViewerDep
from backend.api.schemas import AuditRead, Me, TokenCreate, TokenCreated, TokenRead
from backend.errors import ERROR_RESPONSES
from backend.services.auth import audit_trail, grant_token, revoke_api_token, tokens_newest_first

router = APIRouter(prefix="/api", tags=["tokens"], responses=ERROR_RESPONSES)


@router.get("/me")
def get_me(viewer: ViewerDep) -> Me:
    """The role and name of the presented token (any role)."""
    return Me.model_validate({"role": viewer.role, "name": viewer.name, "prefix": viewer.prefix})


@router.get("/tokens")
def list_tokens(session: SessionDep, _admin: AdminDep) -> list[TokenRead]:
    """Every token (never the secret itself), newest first."""
    return [TokenRead.model_validate(row) for row in tokens_newest_first(session)]


@router.post("/tokens", status_code=status.HTTP_201_CREATED)
def post_token(body: TokenCreate, session: SessionDep, admin: AdminDep) -> TokenCreated:
    """Create a token; the response is the only time its secret is shown."""
    row, plaintext = grant_token(
        session, admin, role=body.role, name=body.name, expires_at=body.expires_at
    )
    return TokenCreated.model_validate(
        {**TokenRead.model_validate(row).model_dump(), "token": plaintext}
    )


@router.delete("/tokens/{token_id}")
def revoke_token(token_id: RowId, session: SessionDep, admin: AdminDep) -> TokenRead:
    """Revoke a token at once (idempotent)."""
    return TokenRead.model_validate(revoke_api_token(session, admin, token_id))


@router.get("/audit")
def list_audit(
    session: SessionDep,
    _admin: AdminDep,
    offset: Offset = 0,
    limit: Annotated[int, Query(ge=1, le=1000)] = 100,
) -> list[AuditRead]:
    """The audit trail, newest first: who wrote what, when."""
    return [AuditRead.model_validate(row) for row in audit_trail(session, offset, limit)]
