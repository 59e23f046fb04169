"""API tokens: creation, lookup by hash, revocation, roles, and the audit trail of writes.

The token routes and `wheelscan token create` call `grant_token` and `revoke_api_token`, which
commit; docs/service.md, "Entities and access".
"""

from __future__ import annotations

import hashlib
import hmac
import secrets
from datetime import datetime
from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import Session

from backend.errors import ForbiddenError, InvalidInputError, NotFoundError, UnauthorizedError
from db.models import ROLES, ApiToken, AuditEvent
from db.types import utc_now

TOKEN_PREFIX = "wst_"


def hash_token(token: str) -> str:
    """sha256 hex of a token: the only form in which tokens are stored."""
    return hashlib.sha256(token.encode("utf-8")).hexdigest()


def create_token(
    session: Session, *, role: str, name: str, expires_at: datetime | None = None
) -> tuple[ApiToken, str]:
    """Create a token with `role`; returns the row and the plaintext, shown only once."""
    if role not in ROLES:
        raise InvalidInputError(f"role must be one of {', '.join(ROLES)}, got {role!r}")
    if expires_at is not None and expires_at <= utc_now():
        raise InvalidInputError(f"expires_at must be in the future, got {expires_at.isoformat()}")
    plaintext = TOKEN_PREFIX + secrets.token_urlsafe(32)
    row = ApiToken(
        name=name,
        role=role,
        token_sha256=hash_token(plaintext),
        prefix=plaintext[:12],
        expires_at=expires_at,
    )
    session.add(row)
    session.flush()
    return row, plaintext


def grant_token(
    session: Session,
    actor: ApiToken | None,
    *,
    role: str,
    name: str,
    expires_at: datetime | None = None,
) -> tuple[ApiToken, str]:
    """Create a token, audited as `actor`'s write (None: the CLI), and commit; returns the
    row and the plaintext, shown only once."""
    row, plaintext = create_token(session, role=role, name=name, expires_at=expires_at)
    record_audit(session, actor, "token.create", "token", row.id, {"role": role})
    session.commit()
    return row, plaintext


def revoke_api_token(session: Session, admin: ApiToken, token_id: int) -> ApiToken:
    """Revoke token `token_id` at once (idempotent: a revoked token keeps its first
    revocation time), audited and committed."""
    row = session.get(ApiToken, token_id)
    if row is None:
        raise NotFoundError(f"token {token_id} not found")
    if row.revoked_at is None:
        row.revoked_at = utc_now()
        record_audit(session, admin, "token.revoke", "token", row.id)
        session.commit()
    return row


def tokens_newest_first(session: Session) -> list[ApiToken]:
    """Every token row, newest first."""
    return list(session.scalars(select(ApiToken).order_by(ApiToken.id.desc())))


def audit_trail(session: Session, offset: int, limit: int) -> list[AuditEvent]:
    """`limit` audit events after the `offset` newest, newest first."""
    return list(
        session.scalars(
            select(AuditEvent).order_by(AuditEvent.id.desc()).offset(offset).limit(limit)
        )
    )


def authenticate(session: Session, token: str | None) -> ApiToken:
    """The live token row for a presented bearer token, or UnauthorizedError."""
    if not token:
        raise UnauthorizedError("missing bearer token: send 'Authorization: Bearer <token>'")
    digest = hash_token(token)
    row = session.scalar(select(ApiToken).where(ApiToken.token_sha256 == digest))
    if row is None or not hmac.compare_digest(row.token_sha256, digest):
        raise UnauthorizedError("unknown token: create one with 'wheelscan token create'")
    now = utc_now()
    if row.revoked_at is not None:
        raise UnauthorizedError(f"token {row.prefix}… was revoked; ask an admin for a new one")
    if row.expires_at is not None and row.expires_at <= now:
        raise UnauthorizedError(f"token {row.prefix}… expired at {row.expires_at.isoformat()}")
    return row


def require_role(token: ApiToken, role: str) -> None:
    """ForbiddenError unless `token` has `role` or a higher one."""
    if ROLES.index(token.role) < ROLES.index(role):
        raise ForbiddenError(f"this needs a {role} token; token {token.prefix}… is {token.role}")


def record_audit(
    session: Session,
    token: ApiToken | None,
    action: str,
    target_type: str,
    target_id: object | None,
    detail: dict[str, Any] | None = None,
) -> AuditEvent:
    """Add an audit event for a write (committed with the write it describes)."""
    event = AuditEvent(
        token_id=token.id if token else None,
        actor=f"token:{token.prefix}…({token.name})" if token else "cli",
        action=action,
        target_type=target_type,
        target_id=None if target_id is None else str(target_id),
        detail=detail or {},
    )
    session.add(event)
    return event
