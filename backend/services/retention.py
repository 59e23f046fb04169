"""Retention of raw frames: remove the camera frames of old passes, keep every result.

A pass started more than `frame_retention_days` ago, closed and with every wheel in a
terminal state, loses its raw frame blobs and the full-size mask and σ layers the workers
pre-rendered from them. Its rows stay: frames (sha256, size, labels), measurements,
per-frame artefacts (centres, mask bits, σ map: the masks and σ maps are still served,
rendered from them) and alarms. The pass is marked `frames_removed_at`; frame images of it
answer 410 Gone. One audit event per pass tells what went, how many blobs and bytes.

Blobs are content-addressed, so one blob may belong to several passes: a blob is deleted
only when no pass that keeps its frames refers to it (as a frame or as a layer). The
database is committed before any file is unlinked: a crash in between leaves unreferenced
blobs (space), never a pass that claims frames it no longer has.

Not covered: an upload or stream that stores a byte-identical frame while a sweep runs
(its blob is written before its rows, so for that moment nothing refers to it) can lose
that blob to the sweep. Identical camera frames across passes come from replayed data,
not from cameras; closing this needs a lock shared by the store's writers and the sweep.

docs/service.md, "Retention, backup".
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Iterable
from dataclasses import dataclass
from datetime import datetime, timedelta
from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import Session, sessionmaker
from starlette.concurrency import run_in_threadpool

from backend.services.auth import record_audit
from backend.storage.store import BlobStore
from db.models import TERMINAL_WHEEL_STATES, Frame, Measurement, MeasurementFrame, Pass, PassWheel
from db.types import utc_now

logger = logging.getLogger(__name__)

PNG_SUFFIX = ".png"
"""Frames and pre-rendered layers share the store's .png namespace."""
_IN_CHUNK = 500
"""sha256 values per IN (...) query, well inside every backend's parameter limit."""


@dataclass(frozen=True, slots=True)
class PassRemoval:
    """What retention removed (or, in a dry run, would remove) of one pass.

    Attributes
    ----------
    pass_id : int
    started_at : datetime
    frames : int
        Frame rows of the pass (kept, marked removed through the pass).
    blobs_removed : int
        Frame and layer blobs deleted from the store.
    bytes_removed : int
        Their size [bytes].
    blobs_kept_shared : int
        Blobs of the pass kept because a pass that keeps its frames refers to them.
    removed_sha256 : tuple of str
        The deleted blobs (`<sha256>.png` in the store).
    """

    pass_id: int
    started_at: datetime
    frames: int
    blobs_removed: int
    bytes_removed: int
    blobs_kept_shared: int
    removed_sha256: tuple[str, ...]


def retention_cutoff(retention_days: float, now: datetime | None = None) -> datetime:
    """Passes started before this instant have expired frames."""
    if retention_days <= 0:
        raise ValueError(f"retention_days must be > 0, got {retention_days}")
    return (now or utc_now()) - timedelta(days=retention_days)


def expired_passes(session: Session, cutoff: datetime) -> list[Pass]:
    """Closed, fully measured passes started before `cutoff` that still have frames, oldest
    first (a pass still receiving or measuring keeps its frames whatever its age)."""
    unfinished = select(PassWheel.pass_id).where(PassWheel.state.not_in(TERMINAL_WHEEL_STATES))
    return list(
        session.scalars(
            select(Pass)
            .where(
                Pass.started_at < cutoff,
                Pass.frames_removed_at.is_(None),
                Pass.state == "closed",
                Pass.id.not_in(unfinished),
            )
            .order_by(Pass.started_at, Pass.id)
        )
    )


def _layer_rows(session: Session, pass_id: int) -> list[MeasurementFrame]:
    return list(
        session.scalars(
            select(MeasurementFrame)
            .join(Measurement, MeasurementFrame.measurement_id == Measurement.id)
            .join(PassWheel, Measurement.pass_wheel_id == PassWheel.id)
            .where(PassWheel.pass_id == pass_id)
        )
    )


def _chunks(values: list[str]) -> Iterable[list[str]]:
    for start in range(0, len(values), _IN_CHUNK):
        yield values[start : start + _IN_CHUNK]


def _still_used(session: Session, sha256s: set[str], gone: set[int]) -> set[str]:
    """Those of `sha256s` a pass keeping its frames (not in `gone`) refers to."""
    used: set[str] = set()
    keeps = Pass.frames_removed_at.is_(None) & Pass.id.not_in(gone)
    for chunk in _chunks(sorted(sha256s)):
        used.update(
            session.scalars(
                select(Frame.sha256)
                .join(Pass, Frame.pass_id == Pass.id)
                .where(keeps, Frame.sha256.in_(chunk))
            )
        )
        for column in (MeasurementFrame.mask_png_sha256, MeasurementFrame.sigma_png_sha256):
            used.update(
                session.scalars(
                    select(column)
                    .join(Measurement, MeasurementFrame.measurement_id == Measurement.id)
                    .join(PassWheel, Measurement.pass_wheel_id == PassWheel.id)
                    .join(Pass, PassWheel.pass_id == Pass.id)
                    .where(keeps, column.in_(chunk))
                )
            )
    return used


def _plan(
    session: Session, store: BlobStore, train_pass: Pass, gone: set[int]
) -> tuple[PassRemoval, list[MeasurementFrame]]:
    frames = list(session.scalars(select(Frame.sha256).where(Frame.pass_id == train_pass.id)))
    layers = _layer_rows(session, train_pass.id)
    candidates = set(frames) | {
        sha
        for row in layers
        for sha in (row.mask_png_sha256, row.sigma_png_sha256)
        if sha is not None
    }
    shared = _still_used(session, candidates, gone | {train_pass.id})
    removable = sorted(sha for sha in candidates - shared if store.has(sha, PNG_SUFFIX))
    removal = PassRemoval(
        pass_id=train_pass.id,
        started_at=train_pass.started_at,
        frames=len(frames),
        blobs_removed=len(removable),
        bytes_removed=sum(store.path_for(sha, PNG_SUFFIX).stat().st_size for sha in removable),
        blobs_kept_shared=len(candidates & shared),
        removed_sha256=tuple(removable),
    )
    return removal, layers


def _audit_detail(removal: PassRemoval, retention_days: float, cutoff: datetime) -> dict[str, Any]:
    return {
        "removed": "raw frames and pre-rendered mask/σ layers; results kept",
        "retention_days": retention_days,
        "cutoff": cutoff.isoformat(),
        "frames": removal.frames,
        "blobs_removed": removal.blobs_removed,
        "bytes_removed": removal.bytes_removed,
        "blobs_kept_shared": removal.blobs_kept_shared,
        "removed_sha256": list(removal.removed_sha256),
    }


def remove_expired_frames(
    session: Session,
    store: BlobStore,
    retention_days: float,
    *,
    dry_run: bool = False,
    now: datetime | None = None,
    actor: str = "retention",
) -> list[PassRemoval]:
    """Apply frame retention once; returns what was (or, with `dry_run`, would be) removed.

    Each pass is committed (marked, layers unlinked from its rows, audited) before its
    blobs are deleted. A dry run changes nothing and reports the same figures.
    """
    now = now or utc_now()
    cutoff = retention_cutoff(retention_days, now)
    removals = []
    gone: set[int] = set()
    for train_pass in expired_passes(session, cutoff):
        removal, layers = _plan(session, store, train_pass, gone)
        removals.append(removal)
        gone.add(train_pass.id)
        if dry_run:
            continue
        train_pass.frames_removed_at = now
        for row in layers:
            row.mask_png_sha256 = None
            row.sigma_png_sha256 = None
        event = record_audit(
            session,
            None,
            "retention.remove_frames",
            "pass",
            train_pass.id,
            _audit_detail(removal, retention_days, cutoff),
        )
        event.actor, event.at = actor, now
        session.commit()
        for sha in removal.removed_sha256:
            store.path_for(sha, PNG_SUFFIX).unlink(missing_ok=True)
        logger.info(
            "retention: pass %d lost %d blob(s), %d bytes (%d kept, shared)",
            removal.pass_id,
            removal.blobs_removed,
            removal.bytes_removed,
            removal.blobs_kept_shared,
        )
    if dry_run:
        session.rollback()
    return removals


async def sweep_periodically(
    session_factory: sessionmaker[Session],
    store: BlobStore,
    retention_days: float,
    interval_s: float,
) -> None:
    """Apply frame retention every `interval_s` until cancelled (the server's lifespan);
    the work runs in a thread, never on the event loop."""

    def sweep() -> None:
        with session_factory() as session:
            remove_expired_frames(session, store, retention_days, actor="retention sweep")

    while True:
        try:
            await run_in_threadpool(sweep)
        except Exception:
            logger.exception("retention sweep failed; trying again in %.0f s", interval_s)
        await asyncio.sleep(interval_s)
